//! Position encoder.
//!
//! # For firmware
//! Positions are raw encoder increments; the counts per revolution come from [`Encoder::resolution`].
//!
//! # For boards
//! `position` returns the value latched at the last PWM-synchronous sample, never a value torn
//! between two reads.

/// Why a position could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncoderFault {
    /// No signal (cable, power).
    SignalLoss,
    /// Serial frame failed its CRC.
    Crc,
    /// The position jumped further than physically possible since the last sample.
    ImplausibleJump,
}

/// A rotary position encoder.
pub trait Encoder {
    /// Increments per mechanical revolution.
    fn resolution(&self) -> u32;
    /// Multi-turn position in increments.
    fn position(&mut self) -> Result<i64, EncoderFault>;
    /// The position (increments, as [`Encoder::position`] counts them) of the last index pulse
    /// since the previous call, `None` if none was seen: the counter value an incremental
    /// interface captured on Z; an absolute encoder driver reports its single-turn zero crossing
    /// (the once-per-revolution reference absolute servos offer for homing in its place).
    fn take_index(&mut self) -> Option<i64>;
}
