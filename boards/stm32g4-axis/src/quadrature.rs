//! An incremental ABZ encoder on a 32-bit timer in encoder mode ([`hal::encoder::Encoder`]).
//!
//! The timer counts every edge of A and B (x4) into its 32-bit counter, which wraps; the driver
//! extends it to the firmware's 64-bit multi-turn position by adding the signed difference to
//! the previous reading (exact as long as fewer than 2³¹ increments pass between two readings:
//! at 40 kHz that is 8.6 × 10¹³ increments/s). The index pulse (Z) captures the counter on a
//! capture channel, whose value is placed on the same 64-bit scale against the reading of the
//! same sample. A cable fault reported by the line receiver is [`EncoderFault::SignalLoss`]; the
//! count goes on being tracked meanwhile, so a short dropout does not shift the position scale
//! (the firmware faults on the loss regardless).
//!
//! The counter is read in the control interrupt, one ADC sequence (≈ 1–2 µs) after the current
//! sample: at 3000 rpm and 10,000 increments per revolution that is less than one increment.

use hal::encoder::{Encoder, EncoderFault};

use crate::regs::EncoderCounter;

/// The encoder on `counter`.
pub struct QuadratureEncoder<C> {
    counter: C,
    counts_per_rev: u32,
    /// The counter at the last reading, and the position it stood for.
    last: Option<(u32, i64)>,
}

impl<C: EncoderCounter> QuadratureEncoder<C> {
    /// An encoder with `counts_per_rev` increments per revolution (4 × its lines) on `counter`.
    /// The first reading is position 0.
    pub fn new(counter: C, counts_per_rev: u32) -> Self {
        Self {
            counter,
            counts_per_rev,
            last: None,
        }
    }

    /// The counter registers.
    pub fn counter(&self) -> &C {
        &self.counter
    }

    /// The counter registers, to change.
    pub fn counter_mut(&mut self) -> &mut C {
        &mut self.counter
    }

    /// The 64-bit position of counter value `count`, against the last reading (or position 0 at
    /// the first).
    fn extend(&self, count: u32) -> (u32, i64) {
        match self.last {
            // The wrapped difference, read as signed: the shorter way round.
            Some((last_count, last_position)) => {
                let step = count.wrapping_sub(last_count) as i32;
                (count, last_position.saturating_add(i64::from(step)))
            }
            None => (count, 0),
        }
    }
}

impl<C: EncoderCounter> Encoder for QuadratureEncoder<C> {
    fn resolution(&self) -> u32 {
        self.counts_per_rev
    }

    fn position(&mut self) -> Result<i64, EncoderFault> {
        let reading = self.extend(self.counter.count());
        self.last = Some(reading);
        if self.counter.line_fault() {
            return Err(EncoderFault::SignalLoss);
        }
        Ok(reading.1)
    }

    fn take_index(&mut self) -> Option<i64> {
        let captured = self.counter.take_index()?;
        Some(self.extend(captured).1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct FakeCounter {
        count: u32,
        index: Option<u32>,
        fault: bool,
    }

    impl EncoderCounter for FakeCounter {
        fn count(&self) -> u32 {
            self.count
        }
        fn take_index(&mut self) -> Option<u32> {
            self.index.take()
        }
        fn line_fault(&self) -> bool {
            self.fault
        }
    }

    fn encoder(start: u32) -> QuadratureEncoder<FakeCounter> {
        QuadratureEncoder::new(
            FakeCounter {
                count: start,
                ..FakeCounter::default()
            },
            10_000,
        )
    }

    #[test]
    fn the_counter_extends_across_its_wrap_both_ways() {
        let mut e = encoder(u32::MAX - 5);
        assert_eq!(e.resolution(), 10_000);
        assert_eq!(e.position(), Ok(0));
        // Forward across the wrap: −6 → +4 is 10 increments.
        e.counter_mut().count = 4;
        assert_eq!(e.position(), Ok(10));
        // Backward across it again, 30 increments.
        e.counter_mut().count = u32::MAX - 25;
        assert_eq!(e.position(), Ok(-20));
        // Many turns in steps below 2³¹ accumulate beyond 32 bits.
        for _ in 0..10 {
            let c = e.counter().count;
            e.counter_mut().count = c.wrapping_add(0x7000_0000);
            e.position().unwrap();
        }
        assert_eq!(e.position(), Ok(-20 + 10 * 0x7000_0000));
    }

    #[test]
    fn the_index_is_placed_against_the_same_sample() {
        let mut e = encoder(1_000);
        assert_eq!(e.position(), Ok(0));
        e.counter_mut().count = 1_500;
        // Z came at counter 1_200, before this sample's reading of 1_500.
        e.counter_mut().index = Some(1_200);
        assert_eq!(e.position(), Ok(500));
        assert_eq!(e.take_index(), Some(200));
        assert_eq!(e.take_index(), None);
        // An index captured across the wrap (reading at +10, Z at −10).
        let mut e = encoder(u32::MAX - 9);
        e.position().unwrap();
        e.counter_mut().count = 10;
        e.counter_mut().index = Some(u32::MAX - 9);
        assert_eq!(e.position(), Ok(20));
        assert_eq!(e.take_index(), Some(0));
    }

    #[test]
    fn a_cable_fault_is_signal_loss_and_the_count_goes_on() {
        let mut e = encoder(0);
        e.position().unwrap();
        e.counter_mut().count = 100;
        e.counter_mut().fault = true;
        assert_eq!(e.position(), Err(EncoderFault::SignalLoss));
        e.counter_mut().count = 150;
        e.counter_mut().fault = false;
        assert_eq!(e.position(), Ok(150));
    }
}
