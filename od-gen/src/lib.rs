//! od-gen
