//! lasalle
