//! Stage 4: checks.
