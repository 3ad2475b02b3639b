//! An absolute encoder on BiSS-C ([`hal::encoder::Encoder`]): the frame's decoding with its
//! CRC, and the driver that reads one frame per PWM period.
//!
//! # Frame (BiSS-C, unidirectional read of the position)
//! The master clocks MA; the slave's SLO line idles high. After MA starts, the slave answers
//! low (ack, one bit or more for the line and processing delay), then
//!
//! ```text
//! Start (1) · CDS (0) · MT[m−1..0] · ST[s−1..0] · nE · nW · nCRC[5..0] · timeout (0 …)
//! ```
//!
//! most significant bit first. nE and nW are active low (0 = the encoder reports an error or a
//! warning). The CRC is x⁶ + x + 1 (0x43) over MT, ST, nE and nW, initial value 0, sent
//! inverted.
//!
//! # Faults, as the firmware's protections take them
//! - no ack or no start bit in the captured bits (line broken, encoder unpowered, or the frame
//!   not finished by the sample: the transfer timed out): [`EncoderFault::SignalLoss`];
//! - the encoder's own error bit nE: [`EncoderFault::SignalLoss`] (its position is not valid);
//! - a CRC mismatch: [`EncoderFault::Crc`] (the firmware counts these and trips on repeats).
//!
//! # Timing
//! The driver starts the next frame at the end of the control interrupt and reads it at the
//! start of the next one: the position is one PWM period old when the loops use it (the
//! encoder latches at MA's first edge). At 10 MHz a 52-bit frame takes 5.2 µs plus the line
//! delay, well inside a 25 µs period.

use hal::encoder::{Encoder, EncoderFault};

/// The CRC polynomial x⁶ + x + 1 without its x⁶ term.
const CRC6_POLY: u8 = 0x03;
/// The CRC's width.
const CRC_BITS: u32 = 6;
/// The bits of a frame besides the position: start, CDS, nE, nW, CRC.
const OVERHEAD_BITS: u32 = 2 + 2 + CRC_BITS;

/// The position layout of an encoder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BissLayout {
    /// Multi-turn bits (0 for a single-turn encoder).
    pub multi_turn_bits: u8,
    /// Single-turn bits.
    pub single_turn_bits: u8,
}

impl BissLayout {
    /// Position bits (multi-turn + single-turn), at most 56.
    // Overflow-free: two u8 add up to at most 510.
    #[allow(clippy::arithmetic_side_effects)]
    const fn position_bits(&self) -> u32 {
        self.multi_turn_bits as u32 + self.single_turn_bits as u32
    }

    /// Increments per revolution.
    pub const fn counts_per_rev(&self) -> u64 {
        1 << self.single_turn_bits
    }
}

/// A decoded frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BissReading {
    /// Multi-turn × 2^single-turn bits + single-turn: the position in increments, modulo the
    /// encoder's range.
    pub position: u64,
    /// The encoder's warning bit nW was active.
    pub warning: bool,
}

/// Why a frame gave no position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BissError {
    /// No ack, no start bit, or the frame ends before its CRC.
    NoFrame,
    /// The encoder's error bit nE was active.
    EncoderError,
    /// The CRC did not match.
    Crc,
    /// The layout does not fit a frame of this driver (position bits 1..=56).
    Layout,
}

impl From<BissError> for EncoderFault {
    fn from(e: BissError) -> Self {
        match e {
            BissError::Crc => EncoderFault::Crc,
            BissError::NoFrame | BissError::EncoderError | BissError::Layout => {
                EncoderFault::SignalLoss
            }
        }
    }
}

/// The CRC-6 (x⁶ + x + 1, initial value 0, not inverted) of the `bits` low bits of `value`,
/// most significant first.
pub fn crc6(value: u64, bits: u32) -> u8 {
    let mut crc = 0u8;
    for i in (0..bits.min(64)).rev() {
        let bit = ((value >> i) & 1) as u8;
        let feedback = ((crc >> (CRC_BITS - 1)) & 1) ^ bit;
        crc = (crc << 1) & 0x3F;
        if feedback != 0 {
            crc ^= CRC6_POLY;
        }
    }
    crc
}

/// The captured bits, most significant bit of byte 0 first.
struct Bits<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Bits<'a> {
    /// The bits of `bytes`, up to its first `usize::MAX / 8` bytes (far beyond any frame), so
    /// that every bit's index fits a usize.
    fn new(bytes: &'a [u8]) -> Self {
        Self {
            bytes: bytes.get(..usize::MAX / 8).unwrap_or(bytes),
            at: 0,
        }
    }

    // Overflow-free: the byte at at / 8 was there, so at < 8 × len ≤ usize::MAX − 7 (`new`).
    #[allow(clippy::arithmetic_side_effects)]
    fn next(&mut self) -> Option<bool> {
        let byte = self.bytes.get(self.at / 8)?;
        let bit = (byte >> (7 - self.at % 8)) & 1 == 1;
        self.at += 1;
        Some(bit)
    }

    /// The next `n` bits (at most 64) as a number, most significant first.
    fn take(&mut self, n: u32) -> Option<u64> {
        let mut v = 0u64;
        for _ in 0..n {
            v = (v << 1) | u64::from(self.next()?);
        }
        Some(v)
    }
}

/// Decodes a frame from the bits an SPI master captured on SLO while clocking MA (see the
/// module docs).
pub fn decode(frame: &[u8], layout: BissLayout) -> Result<BissReading, BissError> {
    let position_bits = layout.position_bits();
    if position_bits == 0 || position_bits > 56 {
        return Err(BissError::Layout);
    }
    let mut bits = Bits::new(frame);
    // Idle high until the slave answers; then the ack (low) until the start bit.
    let mut acked = false;
    loop {
        match (bits.next(), acked) {
            (None, _) => return Err(BissError::NoFrame),
            (Some(false), _) => acked = true,
            (Some(true), true) => break,
            (Some(true), false) => {}
        }
    }
    // CDS, then the data.
    bits.take(1).ok_or(BissError::NoFrame)?;
    // Overflow-free: position_bits ≤ 56 (checked above).
    #[allow(clippy::arithmetic_side_effects)]
    let data_bits = position_bits + 2;
    let data = bits.take(data_bits).ok_or(BissError::NoFrame)?;
    let sent_crc = bits.take(CRC_BITS).ok_or(BissError::NoFrame)? as u8;
    if crc6(data, data_bits) != !sent_crc & 0x3F {
        return Err(BissError::Crc);
    }
    let error = data & 0b10 == 0;
    let warning = data & 0b01 == 0;
    if error {
        return Err(BissError::EncoderError);
    }
    Ok(BissReading {
        position: data >> 2,
        warning,
    })
}

/// The transfer of one frame: a board clocks it on SPI (with DMA) and keeps what SLO gave.
pub trait FrameTransfer {
    /// The bits of the frame started last, if its transfer has finished; `None` if it has not
    /// (or none was started): the frame timed out.
    fn take_frame(&mut self) -> Option<&[u8]>;
    /// Starts clocking the next frame.
    fn start(&mut self);
}

/// The encoder on `transfer`.
pub struct BissEncoder<T> {
    transfer: T,
    layout: BissLayout,
    /// The last good position on the 64-bit scale, and its raw value.
    last: Option<(i64, u64)>,
    /// The revolution boundary crossed by the last reading, if any.
    index: Option<i64>,
}

impl<T: FrameTransfer> BissEncoder<T> {
    /// The encoder of `layout` on `transfer`; the first frame is started now.
    pub fn new(mut transfer: T, layout: BissLayout) -> Result<Self, BissError> {
        let bits = layout.position_bits();
        if bits == 0 || bits > 56 || layout.single_turn_bits >= 32 {
            return Err(BissError::Layout);
        }
        transfer.start();
        Ok(Self {
            transfer,
            layout,
            last: None,
            index: None,
        })
    }

    /// The frame transfer.
    pub fn transfer(&self) -> &T {
        &self.transfer
    }

    /// The frame transfer, to change.
    pub fn transfer_mut(&mut self) -> &mut T {
        &mut self.transfer
    }

    /// The bits of a frame (for a board's frame buffer).
    // Overflow-free: at most 510 position bits (two u8) + 10.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn frame_bits(layout: BissLayout) -> u32 {
        layout.position_bits() + OVERHEAD_BITS
    }

    /// Places `raw` on the 64-bit scale of the previous reading: the shorter way round the
    /// encoder's range (its multi-turn counter wraps).
    fn extend(&self, raw: u64) -> i64 {
        let bits = self.layout.position_bits();
        match self.last {
            None => raw as i64,
            Some((position, last_raw)) => {
                // Sign-extend the difference from the range's width.
                // Overflow-free: `new` keeps bits in 1..=56, so the shift is 8..=63.
                #[allow(clippy::arithmetic_side_effects)]
                let shift = 64 - bits;
                let step = ((raw.wrapping_sub(last_raw) << shift) as i64) >> shift;
                position.saturating_add(step)
            }
        }
    }
}

impl<T: FrameTransfer> Encoder for BissEncoder<T> {
    fn resolution(&self) -> u32 {
        // `new` keeps single-turn bits below 32.
        1 << self.layout.single_turn_bits
    }

    fn position(&mut self) -> Result<i64, EncoderFault> {
        let reading = self
            .transfer
            .take_frame()
            .ok_or(BissError::NoFrame)
            .and_then(|frame| decode(frame, self.layout));
        self.transfer.start();
        let reading = reading?;
        let position = self.extend(reading.position);
        // The single-turn zero crossed since the last good reading: the index.
        if let Some((last, _)) = self.last {
            let cpr = 1i64 << self.layout.single_turn_bits;
            let (from, to) = (last.div_euclid(cpr), position.div_euclid(cpr));
            if from != to {
                self.index = Some(from.max(to).saturating_mul(cpr));
            }
        }
        self.last = Some((position, reading.position));
        Ok(position)
    }

    fn take_index(&mut self) -> Option<i64> {
        self.index.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 20-bit single-turn, 16-bit multi-turn (the reference servo's encoder).
    const LAYOUT: BissLayout = BissLayout {
        multi_turn_bits: 16,
        single_turn_bits: 20,
    };

    /// A frame as SLO sends it: `idle` high bits, `ack` low bits, start, CDS, MT, ST, nE, nW,
    /// nCRC, then low; packed MSB first into 8 bytes.
    fn frame(position: u64, error: bool, warning: bool, idle: u32, ack: u32) -> [u8; 8] {
        let data = (position << 2) | (u64::from(!error) << 1) | u64::from(!warning);
        let data_bits = LAYOUT.position_bits() + 2;
        let crc = !crc6(data, data_bits) & 0x3F;
        let mut bits: u128 = 0;
        let mut n = 0u32;
        let mut push = |v: u64, w: u32| {
            bits = (bits << w) | u128::from(v);
            n += w;
        };
        push((1 << idle) - 1, idle);
        push(0, ack);
        push(0b10, 2);
        push(data, data_bits);
        push(u64::from(crc), 6);
        let total = 64;
        assert!(n <= total);
        let word = (bits << (total - n)) as u64;
        word.to_be_bytes()
    }

    #[test]
    fn the_crc_is_x6_x_1() {
        // The remainder of M(x)·x⁶ mod x⁶ + x + 1: for M = 1 it is x + 1, for M = x⁶ it is
        // (x + 1)² = x² + 1.
        assert_eq!(crc6(1, 1), 0b00_0011);
        assert_eq!(crc6(1 << 6, 7), 0b00_0101);
        // A zero message has CRC 0; the CRC of a message followed by its CRC is 0.
        assert_eq!(crc6(0, 40), 0);
        let msg = 0x2_3456_789A;
        let c = crc6(msg, 38);
        assert_eq!(crc6((msg << 6) | u64::from(c), 44), 0);
    }

    #[test]
    fn a_frame_decodes_whatever_the_line_delay() {
        let position = (0x1234 << 20) | 0x0_ABCDE;
        for (idle, ack) in [(1, 1), (2, 1), (1, 5), (3, 3)] {
            let f = frame(position, false, false, idle, ack);
            assert_eq!(
                decode(&f, LAYOUT),
                Ok(BissReading {
                    position,
                    warning: false
                }),
                "idle {idle}, ack {ack}"
            );
        }
        let f = frame(position, false, true, 1, 1);
        assert_eq!(decode(&f, LAYOUT).map(|r| r.warning), Ok(true));
    }

    #[test]
    fn faults_are_told_apart() {
        let good = frame(42, false, false, 1, 1);
        // Any single flipped bit of the start bit, the data and the CRC is caught (or the frame
        // is lost); the CDS bit (3) is control data outside the CRC.
        for bit in core::iter::once(2).chain(4..(4 + 38 + 6)) {
            let mut f = good;
            f[bit / 8] ^= 0x80 >> (bit % 8);
            assert!(decode(&f, LAYOUT).is_err(), "bit {bit}");
        }
        let mut f = good;
        f[3] ^= 0x01;
        assert_eq!(decode(&f, LAYOUT), Err(BissError::Crc));
        assert_eq!(
            decode(&frame(42, true, false, 1, 1), LAYOUT),
            Err(BissError::EncoderError)
        );
        // A dead line: all high (no ack) or all low (no start).
        assert_eq!(decode(&[0xFF; 8], LAYOUT), Err(BissError::NoFrame));
        assert_eq!(decode(&[0x00; 8], LAYOUT), Err(BissError::NoFrame));
        // A frame cut short.
        assert_eq!(decode(&good[..4], LAYOUT), Err(BissError::NoFrame));
        assert_eq!(
            decode(
                &good,
                BissLayout {
                    multi_turn_bits: 40,
                    single_turn_bits: 20
                }
            ),
            Err(BissError::Layout)
        );
        assert_eq!(EncoderFault::from(BissError::Crc), EncoderFault::Crc);
        assert_eq!(
            EncoderFault::from(BissError::NoFrame),
            EncoderFault::SignalLoss
        );
        assert_eq!(
            EncoderFault::from(BissError::EncoderError),
            EncoderFault::SignalLoss
        );
    }

    /// A transfer that hands out prepared frames, or times out.
    struct Transfer {
        next: Option<[u8; 8]>,
        current: Option<[u8; 8]>,
        started: u32,
    }

    impl FrameTransfer for Transfer {
        fn take_frame(&mut self) -> Option<&[u8]> {
            self.current.as_ref().map(|f| &f[..])
        }
        fn start(&mut self) {
            self.current = self.next.take();
            self.started += 1;
        }
    }

    fn encoder(first: u64) -> BissEncoder<Transfer> {
        BissEncoder::new(
            Transfer {
                next: Some(frame(first, false, false, 1, 1)),
                current: None,
                started: 0,
            },
            LAYOUT,
        )
        .unwrap()
    }

    fn feed(e: &mut BissEncoder<Transfer>, position: u64) -> Result<i64, EncoderFault> {
        e.transfer_mut().next = Some(frame(position, false, false, 1, 1));
        e.position()
    }

    #[test]
    fn positions_extend_across_the_multi_turn_wrap_and_report_the_index() {
        let range = 1u64 << 36;
        let cpr = 1i64 << 20;
        // Starts one revolution below the wrap.
        let mut e = encoder(range - (1 << 20));
        assert_eq!(e.resolution(), 1 << 20);
        // The first frame was started by `new`; reading it starts the next.
        assert_eq!(feed(&mut e, range - 100), Ok((range - (1 << 20)) as i64));
        assert_eq!(e.take_index(), None);
        // Across the wrap: raw 50 is 150 increments further.
        assert_eq!(feed(&mut e, 50), Ok((range - 100) as i64));
        assert_eq!(e.take_index(), None);
        assert_eq!(feed(&mut e, 50), Ok(range as i64 + 50));
        // The single-turn zero at the wrap was crossed: the index is the revolution boundary.
        assert_eq!(e.take_index(), Some(range as i64));
        assert_eq!(e.take_index(), None);
        assert_eq!(range as i64 % cpr, 0);
        // Backwards across it again.
        feed(&mut e, range - 10).unwrap();
        assert_eq!(e.take_index(), None);
        assert_eq!(feed(&mut e, range - 10), Ok(range as i64 - 10));
        assert_eq!(e.take_index(), Some(range as i64));
    }

    #[test]
    fn a_frame_not_finished_is_signal_loss_and_the_next_one_is_started() {
        let mut e = encoder(7);
        e.transfer_mut().next = None;
        assert_eq!(e.position(), Ok(7));
        // The transfer started for this period did not finish.
        assert_eq!(e.position(), Err(EncoderFault::SignalLoss));
        let started = e.transfer().started;
        assert_eq!(feed(&mut e, 9), Err(EncoderFault::SignalLoss));
        assert_eq!(
            e.transfer().started,
            started + 1,
            "a new frame every period"
        );
        assert_eq!(feed(&mut e, 11), Ok(9));
    }
}
