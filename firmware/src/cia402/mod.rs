//! CiA402 (IEC 61800-7-201) drive profile.
//!
//! First cut: the power drive state machine ([`pds`]) only. Modes, homing, limits, the fault
//! reaction and units come with the CiA402 issue.

pub mod pds;
