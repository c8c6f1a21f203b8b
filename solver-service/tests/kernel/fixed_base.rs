//! fixed_base
