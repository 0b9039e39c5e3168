//! Stage 5: emission.
