//! CiA402 (IEC 61800-7-201) drive profile, independent of the fieldbus and of the motor: the
//! power drive system state machine, controlword/statusword, the modes of operation and the
//! set-point each mode gives, unit conversions at the object boundary, and the mapping of
//! internal faults to the profile's error codes (603Fh).
//!
//! | module | what |
//! |---|---|
//! | [`pds`] | the PDS state machine as a pure decision on the controlword; statusword bits |
//! | [`device`] | one cycle of the CiA402 device: controlword → state → statusword, mode display, fault and fault reset |
//! | [`stop`] | stop reactions of the option codes 605Ah–605Eh and the deceleration ramp |
//! | [`limits`] | software position limits 607Dh, limit switches: which motions are blocked; 60FDh |
//! | [`outputs`] | digital outputs 60FEh: the master's forced levels under the bit mask, the brake |
//! | [`modes`] | modes of operation (6060h/6061h) and the set-point each mode hands to the axis |
//! | [`mode_status`] | statusword bits 10–13: what each shows in each mode, CiA402's layouts and a profile's own |
//! | [`homing`] | homing mode: the search sequences of the CiA402 homing methods on latched switch edges and index pulses, homing statusword bits |
//! | [`interpolated_position`] | interpolated position mode: controlword bit 4, statusword bit 12, the interpolation period 60C2h |
//! | [`profile_position`] | the set-point handshake of profile position (controlword bits 4, 5, 6, 9; statusword bit 12; the buffer) |
//! | [`window`] | "inside a window for a time": target reached, speed zero |
//! | [`touch_probe`] | touch probe 60B8h/60B9h: single and continuous trigger, input or index source, latched positions 60BAh–60BDh and counters 60D5h–60D8h, the profile's status bits 6/7 |
//! | [`units`] | conversions between object units (‰ of rated torque, 32-bit positions, µΩ, nH, g·mm²) and SI |
//! | [`faults`] | the profile's error code for each internal fault |
//!
//! The drive application (crate `firmware`) binds these to the object dictionary and to the axis.
#![no_std]
#![deny(missing_docs)]
// Firmware never panics on input: outside tests no unwrap/expect/panic and no unchecked
// indexing or integer arithmetic; each exception states why it cannot fail where it stands.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod device;
pub mod faults;
pub mod homing;
pub mod interpolated_position;
pub mod limits;
pub mod mode_status;
pub mod modes;
pub mod outputs;
pub mod pds;
pub mod profile_position;
pub mod stop;
pub mod touch_probe;
pub mod units;
pub mod window;
