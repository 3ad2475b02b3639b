//! Phase currents, bus voltage and temperature from the injected conversions of ADC1 and
//! ADC2 ([`hal::power::CurrentSense`], [`hal::power::BusSense`]).
//!
//! Every channel is linear: `value = (counts − zero_count) × per_count`. The scales are computed
//! from the circuit ([`LinearScale::current_amplifier`], [`LinearScale::divider`],
//! [`LinearScale::linear_sensor`]) as `const fn`s, so a board states its resistors and gains and
//! never a conversion factor. The zero of a current amplifier is its nominal bias: the firmware
//! measures the real offsets itself at every enable (`hal::power::CurrentSense` returns the
//! currents as measured).
//!
//! Sign: a positive current flows from the inverter into the motor. On a low-side shunt that
//! current flows from the shunt's ground end up through the low-side switch while it conducts,
//! so the board's amplifier is wired to raise its output for it (the usual differential
//! connection with the inputs crossed).

use hal::power::{BusSense, CurrentSense, PhaseCurrents};

use crate::regs::Conversions;

/// `value = (counts − zero_count) × per_count`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearScale {
    /// Counts of a zero value.
    pub zero_count: f32,
    /// Value per count.
    pub per_count: f32,
}

impl LinearScale {
    /// A low-side shunt of `shunt_ohm` with an amplifier of gain `gain` biased at `bias_v`, read
    /// by an ADC of `bits` with reference `vref_v`: amperes per count
    /// `vref / 2^bits / (shunt × gain)`, zero at the bias.
    pub const fn current_amplifier(
        vref_v: f32,
        bits: u32,
        shunt_ohm: f32,
        gain: f32,
        bias_v: f32,
    ) -> Self {
        let volts_per_count = vref_v / (1u32 << bits) as f32;
        Self {
            zero_count: bias_v / volts_per_count,
            per_count: volts_per_count / (shunt_ohm * gain),
        }
    }

    /// A resistor divider `top_ohm` over `bottom_ohm` read by an ADC of `bits` with reference
    /// `vref_v`: volts per count `vref / 2^bits × (top + bottom) / bottom`.
    pub const fn divider(vref_v: f32, bits: u32, top_ohm: f32, bottom_ohm: f32) -> Self {
        let volts_per_count = vref_v / (1u32 << bits) as f32;
        Self {
            zero_count: 0.0,
            per_count: volts_per_count * (top_ohm + bottom_ohm) / bottom_ohm,
        }
    }

    /// A sensor with a linear output, `volts_at_zero` at a value of 0 and `volts_per_unit`
    /// per unit (e.g. 0.5 V at 0 °C and 10 mV/°C), read by an ADC of `bits` with reference
    /// `vref_v`.
    pub const fn linear_sensor(
        vref_v: f32,
        bits: u32,
        volts_at_zero: f32,
        volts_per_unit: f32,
    ) -> Self {
        let volts_per_count = vref_v / (1u32 << bits) as f32;
        Self {
            zero_count: volts_at_zero / volts_per_count,
            per_count: volts_per_count / volts_per_unit,
        }
    }

    /// The value of `counts`.
    pub fn convert(&self, counts: u16) -> f32 {
        (f32::from(counts) - self.zero_count) * self.per_count
    }
}

/// How many phases have a shunt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Shunts {
    /// Phases a and b; c = −a − b (the windings are star-connected without neutral).
    Two,
    /// All three phases, each measured. The firmware's maximum modulation keeps every low-side
    /// window at the valley long enough for the sample.
    Three,
}

/// The analog front end of the board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalogFrontEnd {
    /// Shunt configuration.
    pub shunts: Shunts,
    /// Phase-current channels (the same circuit on every phase).
    pub current: LinearScale,
    /// DC-bus voltage channel.
    pub bus: LinearScale,
    /// Power-stage temperature channel, °C.
    pub temperature: LinearScale,
}

/// The phase currents of the last sample.
pub struct PhaseCurrentSense {
    shunts: Shunts,
    scale: LinearScale,
    counts: [u16; 3],
}

/// Bus voltage and temperature of the last sample.
pub struct BusAndTemperature {
    bus: LinearScale,
    temperature: LinearScale,
    counts: (u16, u16),
}

/// Splits the front end into its current and its bus/temperature parts, both at zero counts
/// until the first [`latch`].
pub fn sensing(front_end: &AnalogFrontEnd) -> (PhaseCurrentSense, BusAndTemperature) {
    (
        PhaseCurrentSense {
            shunts: front_end.shunts,
            scale: front_end.current,
            counts: [0; 3],
        },
        BusAndTemperature {
            bus: front_end.bus,
            temperature: front_end.temperature,
            counts: (0, 0),
        },
    )
}

/// Latches one sample's conversions into both parts (what the trait methods then return).
pub fn latch(currents: &mut PhaseCurrentSense, bus: &mut BusAndTemperature, raw: &Conversions) {
    currents.counts = raw.phase;
    bus.counts = (raw.bus, raw.temperature);
}

impl CurrentSense for PhaseCurrentSense {
    fn phase_currents(&mut self) -> PhaseCurrents {
        let [a, b, c] = self.counts;
        let a = self.scale.convert(a);
        let b = self.scale.convert(b);
        let c = match self.shunts {
            Shunts::Two => -a - b,
            Shunts::Three => self.scale.convert(c),
        };
        PhaseCurrents { a, b, c }
    }
}

impl BusSense for BusAndTemperature {
    fn bus_voltage(&mut self) -> f32 {
        self.bus.convert(self.counts.0)
    }

    fn temperature(&mut self) -> f32 {
        self.temperature.convert(self.counts.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2 mΩ shunt, gain 16 (32 mV/A), biased at 1.65 V, 12-bit ADC at 3.3 V: 25.18 mA per
    /// count, ±51.6 A full scale.
    const CURRENT: LinearScale = LinearScale::current_amplifier(3.3, 12, 0.002, 16.0, 1.65);
    /// 300 kΩ over 10 kΩ: 102.3 V full scale.
    const BUS: LinearScale = LinearScale::divider(3.3, 12, 300_000.0, 10_000.0);
    /// 0.5 V at 0 °C, 10 mV/°C.
    const TEMPERATURE: LinearScale = LinearScale::linear_sensor(3.3, 12, 0.5, 0.010);

    fn close(a: f32, b: f32, tolerance: f32) -> bool {
        (a - b).abs() <= tolerance
    }

    #[test]
    fn scales_come_from_the_circuit() {
        // 3.3 V / 4096 = 0.8057 mV per count; / 32 mV/A = 25.18 mA per count.
        assert!(
            close(CURRENT.per_count, 0.025_177, 1e-6),
            "{}",
            CURRENT.per_count
        );
        assert!(close(CURRENT.zero_count, 2048.0, 1e-3));
        // Full scale: ±2048 counts × 25.18 mA = ±51.56 A.
        assert!(close(CURRENT.convert(4095), 51.54, 0.01));
        assert!(close(CURRENT.convert(0), -51.56, 0.01));
        // 31 × 0.8057 mV = 24.98 mV per count; 48 V is 1922 counts.
        assert!(close(BUS.per_count, 0.024_976, 1e-6), "{}", BUS.per_count);
        assert!(close(BUS.convert(1922), 48.0, 0.03));
        // 0.5 V = 620.6 counts; 25 °C = 0.75 V = 930.9 counts.
        assert!(close(TEMPERATURE.convert(931), 25.0, 0.05));
        assert!(close(TEMPERATURE.convert(621), 0.0, 0.05));
    }

    fn front_end(shunts: Shunts) -> AnalogFrontEnd {
        AnalogFrontEnd {
            shunts,
            current: CURRENT,
            bus: BUS,
            temperature: TEMPERATURE,
        }
    }

    #[test]
    fn two_shunts_give_the_third_phase_by_kirchhoff() {
        let (mut currents, mut bus) = sensing(&front_end(Shunts::Two));
        // +10 A on a (397 counts above the bias), −4 A on b; c's channel reads garbage.
        let raw = Conversions {
            phase: [2048 + 397, 2048 - 159, 4095],
            bus: 1922,
            temperature: 931,
        };
        latch(&mut currents, &mut bus, &raw);
        let i = currents.phase_currents();
        assert!(close(i.a, 10.0, 0.01), "{i:?}");
        assert!(close(i.b, -4.0, 0.01), "{i:?}");
        assert_eq!(i.c, -i.a - i.b);
        assert!(close(bus.bus_voltage(), 48.0, 0.03));
        assert!(close(bus.temperature(), 25.0, 0.05));
    }

    #[test]
    fn three_shunts_measure_every_phase() {
        let (mut currents, mut bus) = sensing(&front_end(Shunts::Three));
        let raw = Conversions {
            phase: [2048 + 397, 2048 - 159, 2048 - 238],
            ..Conversions::default()
        };
        latch(&mut currents, &mut bus, &raw);
        let i = currents.phase_currents();
        assert!(close(i.c, -6.0, 0.01), "{i:?}");
        // Before any latch (or with a dead converter) the readings are the full negative scale,
        // which the firmware's offset check refuses rather than taking for a current.
        let (mut fresh, _) = sensing(&front_end(Shunts::Three));
        assert!(fresh.phase_currents().a < -50.0);
    }
}
