//! Unit tests of the simulated ET1100, one file per register block.
