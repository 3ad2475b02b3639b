//! Position encoders: quadrature ABZ (incremental) and an absolute serial encoder
//! (BiSS/EnDat-like), plus the board-side serial frame decoder.
//!
//! Incremental: the hardware counter is `floor(θm·CPR/2π)` (plus any offset accumulated from
//! faults), wrapping into `u32`. The index pulse is at `index_at_rad + k·2π`; the counter value
//! at the index, `floor(index_at_rad·CPR/2π) + k·CPR`, is latched whenever the rotor crosses it
//! in either direction (the latch reported in a sample is the last crossing since the previous
//! sample). On signal loss the counter stops and no index is latched; when the signal returns
//! the counter continues from the stopped value (the counts moved meanwhile are lost).
//!
//! Absolute serial frame ([`SERIAL_FRAME_LEN`] = 7 bytes, sent MSB first):
//!
//! | byte  | content                                                                     |
//! |-------|-----------------------------------------------------------------------------|
//! | 0..3  | single-turn position, left-aligned in 24 bits (big-endian)                  |
//! | 3..5  | multi-turn counter, big-endian `u16` (0 for a single-turn encoder)           |
//! | 5     | status: bit 0 ([`STATUS_ERROR`]) = encoder error, position invalid; rest 0   |
//! | 6     | CRC-8 over bytes 0..6                                                       |
//!
//! The CRC is CRC-8/I-432-1 (ITU-T I.432.1): polynomial 0x07, init 0x00, no reflection,
//! final XOR 0x55; check value for `"123456789"` is 0xA1. The final XOR makes an all-zero frame
//! invalid, which is how a **signal loss** shows: the interface receives 7 zero bytes (the data
//! line idles low, no frame arrives) and the decoder reports [`SerialFrameError::Crc`].
//!
//! The position is the one latched `sample_delay_s` before the request (the sample instant):
//! it is interpolated linearly in the plant's integration history (the angle at every substep
//! boundary of the last two periods) and, for longer delays, extrapolated back from the oldest
//! stored point with the present speed.

use std::collections::VecDeque;
use std::f64::consts::TAU;

/// Length of the serial frame in bytes.
pub const SERIAL_FRAME_LEN: usize = 7;
/// Status byte bit: the encoder reports an error (position invalid).
pub const STATUS_ERROR: u8 = 0x01;
/// Single-turn resolutions the frame format supports.
pub const SINGLE_TURN_BITS: std::ops::RangeInclusive<u8> = 17..=23;
/// Multi-turn counter width of a multi-turn encoder (0 for a single-turn encoder).
pub const MULTI_TURN_BITS: u8 = 16;
/// Bits of the single-turn field in the frame (the position is left-aligned in it).
const SINGLE_TURN_FIELD_BITS: u8 = 24;
/// CRC-8/I-432-1 generator polynomial (x⁸ + x² + x + 1).
const CRC8_POLY: u8 = 0x07;
/// CRC-8/I-432-1 final XOR.
const CRC8_XOROUT: u8 = 0x55;
/// Byte and bit flipped in the frame by [`EncoderFaultInjection::CrcErrors`] (a data bit).
const CORRUPT_BYTE: usize = 1;
const CORRUPT_MASK: u8 = 0x10;

/// Encoder type and resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EncoderParams {
    /// Quadrature ABZ: counts per mechanical revolution (after x4 decoding), index pulse at
    /// `index_at_rad` (mechanical).
    Incremental {
        /// Counts per mechanical revolution (after x4 decoding).
        counts_per_rev: u32,
        /// Mechanical angle of the index pulse in rad.
        index_at_rad: f64,
    },
    /// Absolute serial (BiSS/EnDat-like): 17..=23 single-turn bits, 0 (single-turn) or 16
    /// multi-turn bits, position sampled `sample_delay_s` before the request.
    Absolute {
        /// Single-turn resolution in bits (17..=23).
        single_turn_bits: u8,
        /// Multi-turn counter bits: 0 (single-turn) or 16.
        multi_turn_bits: u8,
        /// Delay between the position latch and the request, in s.
        sample_delay_s: f64,
    },
}

/// Encoder faults that can be injected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncoderFaultInjection {
    /// Signal lost: incremental → `signal_ok = false` and the counter stops; serial → an
    /// all-zero frame (fails the CRC). Persists until cleared.
    SignalLoss,
    /// Serial only: every frame has a corrupted data bit (fails the CRC). Persists until
    /// cleared. No effect on an incremental encoder.
    CrcErrors,
    /// Serial only: the encoder sets its status error bit (valid CRC). Persists until cleared.
    /// No effect on an incremental encoder.
    StatusError,
    /// A one-off position jump: `counts` are added to the reading once (an event, not a
    /// state: the reading stays shifted and no fault remains active afterwards).
    Jump {
        /// Counts added to the reading (encoder counts; serial: single-turn LSBs).
        counts: i64,
    },
}

/// What the encoder interface delivers at a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncoderSample {
    /// Quadrature counter.
    Incremental {
        /// Hardware counter value (wrapping).
        count: u32,
        /// Counter value latched at the last index pulse since the previous sample.
        index_count: Option<u32>,
        /// `false` while the encoder signal is lost.
        signal_ok: bool,
    },
    /// Serial frame as received; `frame[..len]` is valid.
    Serial {
        /// Received bytes.
        frame: [u8; 8],
        /// Number of received bytes.
        len: u8,
    },
}

/// A decoded serial position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialPosition {
    /// Single-turn position in LSBs (`0 .. 2^single_turn_bits`).
    pub single_turn: u32,
    /// Multi-turn counter (0 for a single-turn encoder).
    pub multi_turn: u16,
}

/// Why a serial frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SerialFrameError {
    /// CRC mismatch (corrupted frame, or no frame: all zeros).
    Crc,
    /// Wrong frame length.
    Length,
    /// The encoder reported an error in its status byte.
    Status,
    /// The requested resolution is not supported by the frame format.
    Resolution,
}

/// CRC-8/I-432-1 of `data` (see the module doc).
pub fn crc8(data: &[u8]) -> u8 {
    // A byte at a time from the table: the simulation encodes and decodes a frame every PWM
    // period of every axis.
    let crc = data
        .iter()
        .fold(0u8, |crc, &byte| CRC8_TABLE[usize::from(crc ^ byte)]);
    crc ^ CRC8_XOROUT
}

/// The CRC register after shifting each byte value through it bit by bit (MSB first).
const CRC8_TABLE: [u8; 256] = crc8_table();

const fn crc8_table() -> [u8; 256] {
    let mut table = [0u8; 256];
    let mut byte = 0;
    while byte < 256 {
        let mut crc = byte as u8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ CRC8_POLY
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[byte] = crc;
        byte += 1;
    }
    table
}

fn resolution_ok(single_turn_bits: u8, multi_turn_bits: u8) -> bool {
    SINGLE_TURN_BITS.contains(&single_turn_bits)
        && (multi_turn_bits == 0 || multi_turn_bits == MULTI_TURN_BITS)
}

/// Builds a valid frame for a position and status byte.
pub fn encode_serial_frame(pos: SerialPosition, single_turn_bits: u8, status: u8) -> [u8; 8] {
    let st = pos.single_turn << (SINGLE_TURN_FIELD_BITS - single_turn_bits);
    let [_, s0, s1, s2] = st.to_be_bytes();
    let [m0, m1] = pos.multi_turn.to_be_bytes();
    let mut frame = [s0, s1, s2, m0, m1, status, 0, 0];
    frame[SERIAL_FRAME_LEN - 1] = crc8(&frame[..SERIAL_FRAME_LEN - 1]);
    frame
}

/// Board-side decoder of the serial frame (what an encoder interface peripheral + driver does).
pub fn decode_serial_frame(
    frame: &[u8],
    single_turn_bits: u8,
    multi_turn_bits: u8,
) -> Result<SerialPosition, SerialFrameError> {
    if !resolution_ok(single_turn_bits, multi_turn_bits) {
        return Err(SerialFrameError::Resolution);
    }
    if frame.len() != SERIAL_FRAME_LEN {
        return Err(SerialFrameError::Length);
    }
    if crc8(&frame[..SERIAL_FRAME_LEN - 1]) != frame[SERIAL_FRAME_LEN - 1] {
        return Err(SerialFrameError::Crc);
    }
    if frame[5] & STATUS_ERROR != 0 {
        return Err(SerialFrameError::Status);
    }
    let st = u32::from_be_bytes([0, frame[0], frame[1], frame[2]]);
    let multi_turn = if multi_turn_bits == 0 {
        0
    } else {
        u16::from_be_bytes([frame[3], frame[4]])
    };
    Ok(SerialPosition {
        single_turn: st >> (SINGLE_TURN_FIELD_BITS - single_turn_bits),
        multi_turn,
    })
}

/// Encoder state inside the plant.
#[derive(Debug, Clone)]
pub(crate) struct EncoderModel {
    params: EncoderParams,
    /// Persistent fault (never `Jump`).
    fault: Option<EncoderFaultInjection>,
    /// Counts added to the ideal reading (jumps, counts lost during a signal loss).
    offset: i64,
    /// Incremental counter value while the signal is lost.
    frozen: Option<i64>,
    /// Index latch since the previous sample.
    index_latch: Option<u32>,
    /// `(t, θm)` at the substep boundaries of the recent past, oldest first.
    history: VecDeque<(f64, f64)>,
    history_cap: usize,
}

impl EncoderModel {
    pub(crate) fn new(params: EncoderParams, history_cap: usize, t: f64, theta: f64) -> Self {
        let mut m = EncoderModel {
            params,
            fault: None,
            offset: 0,
            frozen: None,
            index_latch: None,
            history: VecDeque::with_capacity(history_cap),
            history_cap,
        };
        m.reset_history(t, theta);
        m
    }

    fn raw_incremental(theta: f64, cpr: u32) -> i64 {
        (theta * f64::from(cpr) / TAU).floor() as i64
    }

    fn incremental_reading(&self, theta: f64, cpr: u32) -> i64 {
        self.frozen
            .unwrap_or_else(|| Self::raw_incremental(theta, cpr) + self.offset)
    }

    /// Forgets the history (after a teleport of the rotor).
    pub(crate) fn reset_history(&mut self, t: f64, theta: f64) {
        self.history.clear();
        self.history.push_back((t, theta));
    }

    /// Records the angle at a substep boundary and latches index crossings.
    pub(crate) fn record(&mut self, t: f64, theta_prev: f64, theta: f64) {
        if self.history.len() == self.history_cap {
            self.history.pop_front();
        }
        self.history.push_back((t, theta));
        if let EncoderParams::Incremental {
            counts_per_rev,
            index_at_rad,
        } = self.params
        {
            if self.fault == Some(EncoderFaultInjection::SignalLoss) {
                return;
            }
            let k_prev = ((theta_prev - index_at_rad) / TAU).floor();
            let k_new = ((theta - index_at_rad) / TAU).floor();
            if k_prev != k_new {
                // The boundary crossed is index_at_rad + k·2π with k the larger region index.
                let k = k_prev.max(k_new) as i64;
                let at_index = Self::raw_incremental(index_at_rad, counts_per_rev)
                    + k * i64::from(counts_per_rev);
                self.index_latch = Some((at_index + self.offset) as u32);
            }
        }
    }

    /// Injects or clears a fault; `theta` is the present angle (for the counter freeze).
    pub(crate) fn set_fault(&mut self, fault: Option<EncoderFaultInjection>, theta: f64) {
        // Leaving a signal loss: the counter resumes from the stopped value.
        if let (Some(frozen), EncoderParams::Incremental { counts_per_rev, .. }) =
            (self.frozen.take(), &self.params)
        {
            self.offset = frozen - Self::raw_incremental(theta, *counts_per_rev);
        }
        self.fault = match fault {
            Some(EncoderFaultInjection::Jump { counts }) => {
                self.offset = self.offset.wrapping_add(counts);
                None
            }
            other => other,
        };
        if let (
            Some(EncoderFaultInjection::SignalLoss),
            EncoderParams::Incremental { counts_per_rev, .. },
        ) = (self.fault, &self.params)
        {
            self.frozen = Some(self.incremental_reading(theta, *counts_per_rev));
        }
    }

    /// Angle at time `t` from the history (see the module doc).
    fn angle_at(&self, t: f64, omega: f64) -> f64 {
        let (&(t_first, th_first), &(t_last, th_last)) =
            match (self.history.front(), self.history.back()) {
                (Some(f), Some(l)) => (f, l),
                _ => return 0.0, // the history is never empty; no panic regardless
            };
        if t >= t_last {
            return th_last + omega * (t - t_last);
        }
        if t <= t_first {
            return th_first - omega * (t_first - t);
        }
        // The entries (t_{k-1}, t_k] that hold t, searched from the newest: the latch delay is
        // a small part of the history.
        let mut next = (t_last, th_last);
        for &(tk, thk) in self.history.iter().rev().skip(1) {
            if tk < t {
                let frac = (t - tk) / (next.0 - tk);
                return thk + frac * (next.1 - thk);
            }
            next = (tk, thk);
        }
        th_last
    }

    /// Encoder output at time `t` for the present angle and speed.
    pub(crate) fn sample(&mut self, t: f64, theta: f64, omega: f64) -> EncoderSample {
        match self.params {
            EncoderParams::Incremental { counts_per_rev, .. } => EncoderSample::Incremental {
                count: self.incremental_reading(theta, counts_per_rev) as u32,
                index_count: self.index_latch.take(),
                signal_ok: self.fault != Some(EncoderFaultInjection::SignalLoss),
            },
            EncoderParams::Absolute {
                single_turn_bits,
                multi_turn_bits,
                sample_delay_s,
            } => {
                let len = SERIAL_FRAME_LEN as u8;
                if self.fault == Some(EncoderFaultInjection::SignalLoss) {
                    return EncoderSample::Serial { frame: [0; 8], len };
                }
                let latched = self.angle_at(t - sample_delay_s, omega);
                let per_turn = 1i64 << single_turn_bits;
                let total = (latched / TAU * per_turn as f64).floor() as i64 + self.offset;
                let multi_turn = if multi_turn_bits == 0 {
                    0
                } else {
                    // Wraps at 2^16 (truncation of the two's-complement turn count).
                    total.div_euclid(per_turn) as u16
                };
                let pos = SerialPosition {
                    single_turn: total.rem_euclid(per_turn) as u32,
                    multi_turn,
                };
                let status = if self.fault == Some(EncoderFaultInjection::StatusError) {
                    STATUS_ERROR
                } else {
                    0
                };
                let mut frame = encode_serial_frame(pos, single_turn_bits, status);
                if self.fault == Some(EncoderFaultInjection::CrcErrors) {
                    frame[CORRUPT_BYTE] ^= CORRUPT_MASK;
                }
                EncoderSample::Serial { frame, len }
            }
        }
    }

    /// Whether the parameters are valid (used by the plant's configuration check).
    pub(crate) fn params_error(params: &EncoderParams) -> Option<&'static str> {
        match *params {
            EncoderParams::Incremental {
                counts_per_rev,
                index_at_rad,
            } => {
                if counts_per_rev == 0 {
                    Some("encoder counts_per_rev must be > 0")
                } else if !index_at_rad.is_finite() {
                    Some("encoder index_at_rad must be finite")
                } else {
                    None
                }
            }
            EncoderParams::Absolute {
                single_turn_bits,
                multi_turn_bits,
                sample_delay_s,
            } => {
                if !SINGLE_TURN_BITS.contains(&single_turn_bits) {
                    Some("encoder single_turn_bits must be 17..=23")
                } else if !resolution_ok(single_turn_bits, multi_turn_bits) {
                    Some("encoder multi_turn_bits must be 0 or 16")
                } else if !(sample_delay_s.is_finite() && sample_delay_s >= 0.0) {
                    Some("encoder sample_delay_s must be finite and >= 0")
                } else {
                    None
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_check_value() {
        assert_eq!(crc8(b"123456789"), 0xA1);
    }

    #[test]
    fn frame_round_trips() {
        for &(st_bits, mt_bits) in &[(17u8, 0u8), (20, 16), (23, 16)] {
            for &(st, mt) in &[
                (0u32, 0u16),
                (1, 1),
                ((1 << st_bits) - 1, u16::MAX),
                (12345, 777),
            ] {
                let pos = SerialPosition {
                    single_turn: st,
                    multi_turn: if mt_bits == 0 { 0 } else { mt },
                };
                let frame = encode_serial_frame(pos, st_bits, 0);
                let decoded = decode_serial_frame(&frame[..SERIAL_FRAME_LEN], st_bits, mt_bits);
                assert_eq!(decoded, Ok(pos));
            }
        }
    }

    #[test]
    fn corrupted_missing_and_error_frames_are_rejected() {
        let pos = SerialPosition {
            single_turn: 0x5_1234,
            multi_turn: 42,
        };
        let frame = encode_serial_frame(pos, 20, 0);
        // Every single-bit error is caught by the CRC.
        for byte in 0..SERIAL_FRAME_LEN {
            for bit in 0..8 {
                let mut f = frame;
                f[byte] ^= 1 << bit;
                assert_eq!(
                    decode_serial_frame(&f[..SERIAL_FRAME_LEN], 20, 16),
                    Err(SerialFrameError::Crc)
                );
            }
        }
        assert_eq!(
            decode_serial_frame(&[0; SERIAL_FRAME_LEN], 20, 16),
            Err(SerialFrameError::Crc)
        );
        assert_eq!(
            decode_serial_frame(&frame[..6], 20, 16),
            Err(SerialFrameError::Length)
        );
        let err = encode_serial_frame(pos, 20, STATUS_ERROR);
        assert_eq!(
            decode_serial_frame(&err[..SERIAL_FRAME_LEN], 20, 16),
            Err(SerialFrameError::Status)
        );
        assert_eq!(
            decode_serial_frame(&frame[..SERIAL_FRAME_LEN], 16, 16),
            Err(SerialFrameError::Resolution)
        );
    }
}
