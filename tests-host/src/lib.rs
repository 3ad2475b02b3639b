//! tests-host
