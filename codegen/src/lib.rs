//! lasalle-codegen
