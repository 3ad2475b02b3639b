//! TIM1 as the three-phase inverter ([`hal::power::Inverter`]).
//!
//! # Duty and compare value
//! The phases run in PWM mode 2 on a centre-aligned counter (RM0440 §29.3.13): a phase's
//! high-side switch conducts while the counter is at or above its compare value, so over one
//! period of 2 × ARR ticks it conducts 2 × (ARR − CCR) ticks and
//!
//! ```text
//! duty = (ARR − CCR) / ARR        CCR = round(ARR × (1 − duty))
//! ```
//!
//! CCR = ARR is a duty of 0 (low side on all period), CCR = 0 a duty of 1. Every low-side switch
//! conducts at the valley, where the update event samples the currents.
//!
//! # Gate enable, disable and the break
//! - [`Inverter::set_duties`] writes the preloaded compare registers: they act from the next
//!   update event, the next period.
//! - [`Inverter::enable`] arms the main output enable; [`Tim1Inverter::start_period`], the first
//!   thing the control interrupt does after the update event, sets MOE. The first switched
//!   period is thus one whose duties the control loop computed for it (`hal::power`); it starts
//!   switching after the interrupt's entry latency (the ADC conversions, ≈ 1–2 µs), with both
//!   switches of every leg off until then.
//! - [`Inverter::disable`] clears MOE at once: every output goes to its idle level (off).
//! - The break input (over-current comparator and gate-driver fault, wired-OR on BKIN) clears
//!   MOE in hardware, with no software on the path. The driver sees the break flag at the next
//!   `start_period`, reports it once through [`Inverter::take_hardware_trip`], and refuses to
//!   switch again until [`Inverter::disable`] and then [`Inverter::enable`] are called: the
//!   firmware latches an over-current fault, and only its fault reset brings the gates back
//!   (automatic output enable, AOE, stays off for that reason).
//!
//! # Bootstrap pre-charge
//! A gate driver whose high sides run from bootstrap capacitors cannot switch a high side on
//! before its capacitor has charged through the low side. With a pre-charge of `n` periods
//! ([`Tim1Inverter::with_bootstrap_precharge`]) the first `n` switched periods after an enable
//! keep every high side off and every low side on (duty 0 on all phases: the zero voltage
//! vector, the voltage the loop asks at its start anyway); the loop's duties follow from the
//! next period on.

use hal::power::Inverter;

use crate::phase_lock::{PeriodDither, PeriodTrim};
use crate::regs::PwmTimer;

/// The compare value of `duty` (0.0..=1.0, clamped; NaN is 0.5, no voltage) for a counter
/// turning at `auto_reload`, in PWM mode 2 (see the module docs).
#[inline]
pub fn compare_for_duty(duty: f32, auto_reload: u16) -> u16 {
    let arr = f32::from(auto_reload);
    // The ticks with the high side off, rounded to the nearest.
    let off = (1.0 - duty) * arr + 0.5;
    // A duty above 1 gives less than half a tick: 0. NaN fails both comparisons: the centre.
    let off = if off >= 0.5 {
        off
    } else if off < 0.5 {
        0.0
    } else {
        0.5 * arr + 0.5
    };
    // `as` saturates (a duty below 0 gives more than ARR ticks); `min` keeps it in the period.
    (off as u16).min(auto_reload)
}

/// The duty a compare value gives (the inverse of [`compare_for_duty`]).
pub fn duty_of_compare(compare: u16, auto_reload: u16) -> f32 {
    if auto_reload == 0 {
        return 0.0;
    }
    let arr = f32::from(auto_reload);
    (arr - f32::from(compare.min(auto_reload))) / arr
}

/// Where the gates are in the enable sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GateState {
    /// MOE cleared, not armed.
    Off,
    /// [`Inverter::enable`] was called: MOE is set at the next period start.
    Armed,
    /// MOE set, switching.
    On,
    /// The break input cleared MOE; stays off until `disable` then `enable`.
    Tripped,
}

/// TIM1 as the inverter.
pub struct Tim1Inverter<T> {
    timer: T,
    pwm_hz: u32,
    gates: GateState,
    /// A trip not yet reported through `take_hardware_trip`.
    trip_unreported: bool,
    /// The compare values written last (active from the next update event).
    compares: [u16; 3],
    /// The period trim of the SYNC0 phase lock, if the PWM is locked to SYNC0.
    trim: Option<&'static PeriodTrim>,
    /// Each period's auto-reload for the trim.
    dither: PeriodDither,
    /// Switched periods of bootstrap pre-charge after each enable, and those left.
    precharge_periods: u16,
    precharge_left: u16,
    /// The auto-reload written last (the next period's), the present period's, and the one of
    /// the period that ended at the last valley.
    arr: [u16; 3],
}

impl<T: PwmTimer> Tim1Inverter<T> {
    /// The inverter on `timer`, configured by the board for `pwm_hz`: gates off (MOE cleared),
    /// every phase at 50 %.
    pub fn new(mut timer: T, pwm_hz: u32) -> Self {
        timer.set_main_output(false);
        let centre = compare_for_duty(0.5, timer.auto_reload());
        let compares = [centre; 3];
        timer.set_compares(compares);
        // A break flag from before (reset, configuration) is no trip of this run.
        let _ = timer.take_break();
        let nominal = timer.auto_reload();
        let dither = PeriodDither::new(nominal);
        Self {
            timer,
            pwm_hz,
            gates: GateState::Off,
            trip_unreported: false,
            compares,
            trim: None,
            dither,
            precharge_periods: 0,
            precharge_left: 0,
            arr: [nominal; 3],
        }
    }

    /// Pre-charges the bootstrap capacitors for `periods` switched periods after each enable
    /// (see the module docs).
    pub fn with_bootstrap_precharge(mut self, periods: u16) -> Self {
        self.precharge_periods = periods;
        self
    }

    /// Trims the PWM period from now on by what `trim` holds (the SYNC0 phase lock sets it):
    /// [`Self::start_period`] sets each next period's auto-reload.
    pub fn with_period_trim(mut self, trim: &'static PeriodTrim) -> Self {
        self.trim = Some(trim);
        self
    }

    /// The start of a PWM period, right after its update event (first thing in the control
    /// interrupt): sets the next period's length (with a period trim), takes the break flag, and
    /// sets MOE if the gates were armed. The compare values written after this are computed
    /// against the new auto-reload; both take effect at the same update event.
    pub fn start_period(&mut self) {
        // The preload written last is the present period's now.
        self.arr = [self.arr[0], self.arr[0], self.arr[1]];
        if let Some(trim) = self.trim {
            let arr = self.dither.next_arr(trim.get());
            self.timer.set_auto_reload(arr);
            self.arr[0] = arr;
        }
        if self.timer.take_break() {
            // The hardware has cleared MOE already; clear it here too, so that nothing this
            // driver does later can set it before the firmware's disable/enable.
            self.timer.set_main_output(false);
            self.gates = GateState::Tripped;
            self.trip_unreported = true;
            return;
        }
        if self.gates == GateState::Armed {
            self.timer.set_main_output(true);
            self.gates = GateState::On;
        }
        // A pre-charge period starts now (its compares were written in the last period).
        if self.gates == GateState::On {
            self.precharge_left = self.precharge_left.saturating_sub(1);
        }
    }

    /// Timer ticks of the PWM period that ended at the last valley (2 × its auto-reload), as
    /// of the last [`Self::start_period`].
    pub fn ended_period_ticks(&self) -> u32 {
        2 * u32::from(self.arr[2])
    }

    /// Where the gates are.
    pub fn gates(&self) -> GateState {
        self.gates
    }

    /// The compare values written last (active from the next update event).
    pub fn compares(&self) -> [u16; 3] {
        self.compares
    }

    /// The timer's registers.
    pub fn timer(&self) -> &T {
        &self.timer
    }

    /// The timer's registers, to change (the SYNC0 phase lock trims its period).
    pub fn timer_mut(&mut self) -> &mut T {
        &mut self.timer
    }
}

impl<T: PwmTimer> Inverter for Tim1Inverter<T> {
    fn pwm_frequency_hz(&self) -> u32 {
        self.pwm_hz
    }

    fn set_duties(&mut self, a: f32, b: f32, c: f32) {
        // The ARR written last: the next period's, which these compares act in.
        let arr = self.arr[0];
        self.compares = if self.precharge_left > 0 {
            // Duty 0: every low side on for the whole next period.
            [arr; 3]
        } else {
            [
                compare_for_duty(a, arr),
                compare_for_duty(b, arr),
                compare_for_duty(c, arr),
            ]
        };
        self.timer.set_compares(self.compares);
    }

    fn enable(&mut self) {
        // A trip holds until `disable`; from `Armed` or `On` there is nothing to do.
        if self.gates == GateState::Off {
            self.gates = GateState::Armed;
            if self.precharge_periods > 0 {
                // The first switched period is a pre-charge period: duty 0 from now.
                self.precharge_left = self.precharge_periods;
                self.compares = [self.arr[0]; 3];
                self.timer.set_compares(self.compares);
            }
        }
    }

    fn disable(&mut self) {
        self.timer.set_main_output(false);
        self.gates = GateState::Off;
        self.precharge_left = 0;
    }

    fn is_enabled(&self) -> bool {
        matches!(self.gates, GateState::Armed | GateState::On)
    }

    fn take_hardware_trip(&mut self) -> bool {
        core::mem::take(&mut self.trip_unreported)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// TIM1 at 40 kHz from 170 MHz (ARR 2125), as plain memory.
    #[derive(Debug)]
    pub(crate) struct FakeTimer {
        pub arr: u16,
        pub compares: [u16; 3],
        pub moe: bool,
        pub break_flag: bool,
        pub moe_writes: u32,
    }

    impl Default for FakeTimer {
        fn default() -> Self {
            Self {
                arr: ARR_40KHZ,
                compares: [0; 3],
                moe: false,
                break_flag: false,
                moe_writes: 0,
            }
        }
    }

    pub(crate) const ARR_40KHZ: u16 = 2125;

    impl PwmTimer for FakeTimer {
        fn auto_reload(&self) -> u16 {
            self.arr
        }
        fn set_auto_reload(&mut self, arr: u16) {
            self.arr = arr;
        }
        fn set_compares(&mut self, compares: [u16; 3]) {
            self.compares = compares;
        }
        fn set_main_output(&mut self, enabled: bool) {
            self.moe = enabled;
            self.moe_writes += 1;
        }
        fn take_break(&mut self) -> bool {
            core::mem::take(&mut self.break_flag)
        }
    }

    /// What the hardware does on a break: BIF set, MOE cleared asynchronously.
    fn fire_break(inverter: &mut Tim1Inverter<FakeTimer>) {
        let t = inverter.timer_mut();
        t.break_flag = true;
        t.moe = false;
    }

    #[test]
    fn duties_map_to_pwm_mode_2_compare_values() {
        // duty = (ARR − CCR) / ARR with ARR = 2125.
        assert_eq!(compare_for_duty(0.0, ARR_40KHZ), 2125);
        assert_eq!(compare_for_duty(1.0, ARR_40KHZ), 0);
        assert_eq!(compare_for_duty(0.5, ARR_40KHZ), 1063); // 1062.5 rounds up
        assert_eq!(compare_for_duty(0.25, ARR_40KHZ), 1594); // 1593.75
        assert_eq!(compare_for_duty(0.95, ARR_40KHZ), 106); // 106.25
                                                            // Out of range and NaN: clamped, or no voltage.
        assert_eq!(compare_for_duty(-0.3, ARR_40KHZ), 2125);
        assert_eq!(compare_for_duty(7.0, ARR_40KHZ), 0);
        assert_eq!(compare_for_duty(f32::NAN, ARR_40KHZ), 1063);
        assert_eq!(compare_for_duty(f32::INFINITY, ARR_40KHZ), 0);
        assert_eq!(compare_for_duty(f32::NEG_INFINITY, ARR_40KHZ), 2125);
        // The round trip is within half a tick.
        for i in 0..=100 {
            let d = i as f32 / 100.0;
            let back = duty_of_compare(compare_for_duty(d, ARR_40KHZ), ARR_40KHZ);
            assert!(
                (back - d).abs() <= 0.5 / f32::from(ARR_40KHZ) + 1e-6,
                "{d} → {back}"
            );
        }
        assert_eq!(duty_of_compare(0, 0), 0.0);
    }

    #[test]
    fn a_new_inverter_is_off_at_fifty_percent() {
        let inv = Tim1Inverter::new(
            FakeTimer {
                moe: true,
                break_flag: true,
                ..FakeTimer::default()
            },
            40_000,
        );
        assert!(!inv.timer().moe);
        assert_eq!(inv.timer().compares, [1063; 3]);
        assert!(!inv.is_enabled());
        assert_eq!(inv.pwm_frequency_hz(), 40_000);
        // The stale break flag was cleared, not reported as a trip.
        let mut inv = inv;
        inv.start_period();
        assert!(!inv.take_hardware_trip());
    }

    #[test]
    fn enable_switches_from_the_next_period_start() {
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000);
        inv.set_duties(0.25, 0.5, 0.75);
        assert_eq!(inv.timer().compares, [1594, 1063, 531]);
        inv.enable();
        // Enabled as far as the firmware is concerned, but MOE waits for the period start.
        assert!(inv.is_enabled());
        assert!(!inv.timer().moe);
        assert_eq!(inv.gates(), GateState::Armed);
        inv.start_period();
        assert!(inv.timer().moe);
        assert_eq!(inv.gates(), GateState::On);
        // A second enable while on writes nothing.
        let writes = inv.timer().moe_writes;
        inv.enable();
        inv.start_period();
        assert_eq!(inv.timer().moe_writes, writes);
    }

    #[test]
    fn a_bootstrap_precharge_keeps_the_high_sides_off_for_its_periods() {
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000).with_bootstrap_precharge(2);
        // The control interrupt's order: duties, then enable (Output::apply).
        inv.set_duties(0.7, 0.2, 0.5);
        inv.enable();
        assert_eq!(
            inv.timer().compares,
            [ARR_40KHZ; 3],
            "duty 0 for the first period"
        );
        // Period 1 (pre-charge) starts; its interrupt writes period 2: still pre-charge.
        inv.start_period();
        assert!(inv.timer().moe);
        inv.set_duties(0.7, 0.2, 0.5);
        assert_eq!(inv.timer().compares, [ARR_40KHZ; 3]);
        // Period 2 starts; period 3 has the loop's duties.
        inv.start_period();
        inv.set_duties(0.7, 0.2, 0.5);
        assert_eq!(inv.timer().compares, [638, 1700, 1063]);
        // A new enable after a disable pre-charges again.
        inv.disable();
        inv.set_duties(0.7, 0.2, 0.5);
        inv.enable();
        assert_eq!(inv.timer().compares, [ARR_40KHZ; 3]);
        // Without a pre-charge the loop's duties go out from the first period.
        let mut plain = Tim1Inverter::new(FakeTimer::default(), 40_000);
        plain.set_duties(0.7, 0.2, 0.5);
        plain.enable();
        assert_eq!(plain.timer().compares, [638, 1700, 1063]);
    }

    #[test]
    fn disable_acts_at_once() {
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000);
        inv.enable();
        inv.start_period();
        inv.disable();
        assert!(!inv.timer().moe);
        assert!(!inv.is_enabled());
        // Disarmed: the next period does not switch.
        inv.start_period();
        assert!(!inv.timer().moe);
        // A disable while only armed cancels the enable too.
        inv.enable();
        inv.disable();
        inv.start_period();
        assert!(!inv.timer().moe);
    }

    #[test]
    fn a_break_is_reported_once_and_holds_until_disable_then_enable() {
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000);
        inv.enable();
        inv.start_period();
        fire_break(&mut inv);
        inv.start_period();
        assert_eq!(inv.gates(), GateState::Tripped);
        assert!(!inv.is_enabled());
        assert!(inv.take_hardware_trip());
        assert!(!inv.take_hardware_trip(), "reported once");
        // The firmware's output still says "gates on" until it has latched the fault: an
        // enable does not switch again.
        inv.enable();
        inv.start_period();
        assert!(!inv.timer().moe);
        assert_eq!(inv.gates(), GateState::Tripped);
        // Its fault reaction disables; a later enable (after the fault reset) switches again.
        inv.disable();
        inv.enable();
        inv.start_period();
        assert!(inv.timer().moe);
    }

    #[test]
    fn a_period_trim_sets_each_next_period_and_the_compares_follow_it() {
        static TRIM: PeriodTrim = PeriodTrim::new();
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000).with_period_trim(&TRIM);
        // No trim: the nominal period.
        inv.start_period();
        assert_eq!(inv.timer().arr, ARR_40KHZ);
        // +2.5 ticks: periods of 2127 and 2128 that average 2127.5.
        TRIM.set(2 * 256 + 128);
        let mut sum = 0u32;
        for _ in 0..4 {
            inv.start_period();
            let arr = inv.timer().arr;
            assert!(arr == 2127 || arr == 2128, "{arr}");
            sum += u32::from(arr);
            // The duty is computed on the period it will act in.
            inv.set_duties(0.5, 0.0, 1.0);
            assert_eq!(inv.timer().compares, [arr / 2 + arr % 2, arr, 0]);
        }
        assert_eq!(sum, 4 * 2127 + 2);
        // The ARR written at a period start governs the next period: two starts later it is
        // the period that ended.
        let written = inv.timer().arr;
        inv.start_period();
        assert_ne!(inv.ended_period_ticks(), 0);
        inv.start_period();
        assert_eq!(inv.ended_period_ticks(), 2 * u32::from(written));
    }

    #[test]
    fn a_break_while_armed_is_a_trip_too() {
        let mut inv = Tim1Inverter::new(FakeTimer::default(), 40_000);
        inv.enable();
        fire_break(&mut inv);
        inv.start_period();
        assert!(!inv.timer().moe);
        assert!(inv.take_hardware_trip());
    }
}
