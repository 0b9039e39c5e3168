//! lasalle-normal-form
