//! The guided tour (`sim-drive tour`, the default command): one simulated standard drive on a
//! machine with a home switch, an ethercrab master in process, and the drive doing what a
//! machine asks of a servo, step by step over the standard profile's default PDOs (6040h,
//! 607Ah, 6060h / 6041h, 6064h, 6061h) at 1 ms (free run):
//!
//! 1. INIT → OP, enable operation (CiA402 shutdown, switch on, enable operation);
//! 2. homing (6060h = 6) with method 19: find the home switch edge; 6064h reads 0 there;
//! 3. profile position (6060h = 1): a move of 3 revolutions, and a second set-point that waits
//!    in the buffer, back to 1 revolution;
//! 4. cyclic synchronous position (6060h = 8): the master streams one revolution out and back;
//! 5. shutdown and back to INIT.
//!
//! Every change of the statusword (state and mode bits) is printed with its meaning, and the
//! motor's position, speed and q current are plotted into one SVG.

use std::f64::consts::TAU;
use std::path::Path;
use std::time::Duration;

use ethercrab::{MainDevice, MainDeviceConfig, Timeouts};

use crate::inproc::InProcess;
use crate::plant::SwitchParams;
use crate::plot::Plot;
use crate::segment::Segment;

/// The bus cycle, ns (free run).
const CYCLE_NS: u64 = 1_000_000;
/// Increments per revolution of the standard drive's servo.
const CPR: f64 = (1u32 << 20) as f64;
/// Where the machine's home switch starts (revolutions); limit switches at ±5.
const HOME_SWITCH_REV: f64 = 0.4;
const LIMIT_REV: f64 = 5.0;
/// Modes of operation.
const HM: i8 = 6;
const PP: i8 = 1;
const CSP: i8 = 8;
/// Controlwords (CiA402 Table 5) and mode bits.
const SHUTDOWN: u16 = 0x06;
const SWITCH_ON: u16 = 0x07;
const ENABLE_OPERATION: u16 = 0x0F;
const BIT4: u16 = 1 << 4;
/// Statusword bits.
const TARGET_REACHED: u16 = 1 << 10;
const BIT12: u16 = 1 << 12;
const BIT13: u16 = 1 << 13;
/// Homing method: home switch active on the positive side, home where it turns off moving
/// negative.
const HOMING_METHOD: i8 = 19;
/// Ceilings of each step, cycles (a step that takes longer fails the tour).
const STEP_LIMIT: usize = 10_000;

/// What the tour saw, one entry per cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TourSample {
    /// Simulated time, s.
    pub t_s: f64,
    /// 6041h.
    pub statusword: u16,
    /// 6064h.
    pub position: i32,
    /// 6061h.
    pub mode: i8,
    /// The motor's true angle, revolutions.
    pub revolutions: f64,
    /// The motor's true speed, rpm.
    pub rpm: f64,
    /// The motor's q current, A.
    pub iq_a: f64,
}

/// What the tour did.
#[derive(Clone, Debug, Default)]
pub struct TourReport {
    /// Every cycle in OP.
    pub samples: Vec<TourSample>,
    /// 6064h at the end of homing.
    pub homed_position: i32,
    /// The motor's angle at the end of homing, revolutions.
    pub homed_revolutions: f64,
    /// 6064h after the profile-position moves.
    pub pp_position: i32,
    /// The statusword lines printed.
    pub transitions: Vec<String>,
}

/// The name of a CiA402 state from the statusword (Table 30).
pub fn state_name(sw: u16) -> &'static str {
    match sw & 0x6F {
        0x00 | 0x20 => "Not Ready to Switch On",
        0x40 | 0x60 => "Switch On Disabled",
        0x21 => "Ready to Switch On",
        0x23 => "Switched On",
        0x27 => "Operation Enabled",
        0x07 => "Quick Stop Active",
        0x0F | 0x2F => "Fault Reaction Active",
        0x08 | 0x28 => "Fault",
        _ => "?",
    }
}

/// The mode-specific statusword bits of `mode` in words.
fn mode_bits(sw: u16, mode: i8) -> String {
    let on = |bit: u16| sw & bit != 0;
    let mut parts = Vec::new();
    match mode {
        HM => {
            parts.push(match (on(BIT13), on(BIT12), on(TARGET_REACHED)) {
                (false, false, false) => "homing in progress",
                (false, false, true) => "homing not started / interrupted",
                (false, true, false) => "homing attained, moving",
                (false, true, true) => "homing completed",
                (true, _, false) => "homing error, moving",
                (true, _, true) => "homing error, at rest",
            });
        }
        PP => {
            if on(BIT12) {
                parts.push("set-point acknowledged");
            }
            parts.push(if on(TARGET_REACHED) {
                "target reached"
            } else {
                "target not reached"
            });
        }
        _ => {}
    }
    parts.join(", ")
}

/// Runs the tour on a drive of `profile` (its default PDOs must be the standard's), writes the
/// plot to `plot_path`, and calls `log` for every line worth printing.
pub async fn run(
    profile: &str,
    plot_path: &Path,
    log: &mut dyn FnMut(String),
) -> Result<TourReport, Box<dyn std::error::Error>> {
    let mut segment = Segment::new(profile, 1)?;
    {
        let servo = &mut segment.drives_mut()[0].servos[0];
        servo.plant.set_switches(SwitchParams {
            limit_neg_rad: Some(-LIMIT_REV * TAU),
            limit_pos_rad: Some(LIMIT_REV * TAU),
            home_rad: Some(HOME_SWITCH_REV * TAU),
            home_end_rad: None,
            probes: [None; 2],
        });
        // The machine starts somewhere left of the home switch.
        servo.plant.set_rotor_position(-0.3 * TAU);
    }
    let (m, transport) = InProcess::connect(
        segment,
        Timeouts {
            pdu: Duration::from_millis(500),
            eeprom: Duration::from_secs(2),
            mailbox_response: Duration::from_secs(2),
            state_transition: Duration::from_secs(2),
            ..Timeouts::default()
        },
        MainDeviceConfig::default(),
    );
    let transport = tokio::task::spawn_local(transport);
    let md: &MainDevice<'_> = &m.maindevice;
    let mut tour = Tour {
        m: &m,
        report: TourReport::default(),
        last: None,
        log,
    };
    let result = tour.steps(md).await;
    transport.abort();
    result?;
    let report = tour.report;
    plot(&report).write(plot_path)?;
    Ok(report)
}

struct Tour<'a, 'l> {
    m: &'a InProcess,
    report: TourReport,
    /// The statusword and mode last printed.
    last: Option<(u16, i8)>,
    log: &'l mut dyn FnMut(String),
}

type Group =
    ethercrab::SubDeviceGroup<2, 64, ethercrab::DefaultLock, ethercrab::subdevice_group::Op>;

impl Tour<'_, '_> {
    async fn steps(&mut self, md: &MainDevice<'_>) -> Result<(), Box<dyn std::error::Error>> {
        let group = md
            .init_single_group::<2, 64>(self.m.shared.clock().now_fn())
            .await?;
        {
            let sd = group.subdevice(md, 0)?;
            (self.log)(format!("found \"{}\"; INIT → PRE-OP", sd.name()));
            sd.sdo_write(0x6098, 0, HOMING_METHOD).await?;
            sd.sdo_write(0x607C, 0, 0i32).await?;
        }
        let group = group.into_safe_op(md).await?.request_into_op(md).await?;
        (self.log)("SAFE-OP → OP (free run, 1 ms)".into());

        (self.log)("1. enable: shutdown, switch on, enable operation".into());
        for cw in [SHUTDOWN; 10]
            .into_iter()
            .chain([SWITCH_ON; 10])
            .chain([ENABLE_OPERATION; 10])
        {
            self.cycle(md, &group, cw, 0, HM).await?;
        }

        (self.log)(format!(
            "2. homing, method {HOMING_METHOD}: the home switch starts at {HOME_SWITCH_REV} rev"
        ));
        self.until(md, &group, ENABLE_OPERATION | BIT4, 0, HM, |s| {
            s.statusword & (BIT13 | BIT12 | TARGET_REACHED) == BIT12 | TARGET_REACHED
                || s.statusword & BIT13 != 0
        })
        .await?;
        let s = self.latest();
        if s.statusword & BIT13 != 0 {
            return Err("homing failed".into());
        }
        self.report.homed_position = s.position;
        self.report.homed_revolutions = s.revolutions;
        (self.log)(format!(
            "   home found at the switch edge ({:.4} rev of the motor); 6064h = {} there",
            s.revolutions, s.position
        ));

        (self.log)("3. profile position: to +3 rev, then (buffered) back to +1 rev".into());
        let (first, second) = ((3.0 * CPR) as i32, CPR as i32);
        for _ in 0..5 {
            self.cycle(md, &group, ENABLE_OPERATION, first, PP).await?;
        }
        self.until(md, &group, ENABLE_OPERATION | BIT4, first, PP, |s| {
            s.statusword & BIT12 != 0
        })
        .await?;
        self.cycle(md, &group, ENABLE_OPERATION, first, PP).await?;
        self.cycle(md, &group, ENABLE_OPERATION | BIT4, second, PP)
            .await?;
        self.cycle(md, &group, ENABLE_OPERATION, second, PP).await?;
        self.until(md, &group, ENABLE_OPERATION, second, PP, |s| {
            s.statusword & (TARGET_REACHED | BIT12) == TARGET_REACHED
        })
        .await?;
        self.report.pp_position = self.latest().position;
        (self.log)(format!(
            "   at {} increments (target {second})",
            self.report.pp_position
        ));

        (self.log)(
            "4. cyclic synchronous position: the master streams 1 rev out and back in 2 s (a \
             cosine, starting and ending at rest)"
                .into(),
        );
        let start = f64::from(self.latest().position);
        for k in 0..2000 {
            let t = f64::from(k) * 1e-3;
            let target = start + 0.5 * CPR * (1.0 - (0.5 * TAU * t).cos());
            self.cycle(md, &group, ENABLE_OPERATION, target as i32, CSP)
                .await?;
        }
        let hold = start as i32;
        for _ in 0..200 {
            self.cycle(md, &group, ENABLE_OPERATION, hold, CSP).await?;
        }

        (self.log)("5. shutdown, back to INIT".into());
        for _ in 0..20 {
            self.cycle(md, &group, SHUTDOWN, hold, CSP).await?;
        }
        let group = group.into_safe_op(md).await?;
        let group = group.into_pre_op(md).await?;
        let _ = group.into_init(md).await?;
        Ok(())
    }

    fn latest(&self) -> TourSample {
        self.report.samples.last().copied().unwrap_or_default()
    }

    /// Cycles with `cw`/`target`/`mode` until `done` holds (at most [`STEP_LIMIT`] cycles).
    async fn until(
        &mut self,
        md: &MainDevice<'_>,
        group: &Group,
        cw: u16,
        target: i32,
        mode: i8,
        done: impl Fn(&TourSample) -> bool,
    ) -> Result<(), Box<dyn std::error::Error>> {
        for k in 0..STEP_LIMIT {
            let s = self.cycle(md, group, cw, target, mode).await?;
            // The first frames still carry the statusword from before the command.
            if k > 3 && done(&s) {
                return Ok(());
            }
        }
        Err(format!("step did not finish within {STEP_LIMIT} cycles").into())
    }

    /// One cycle (phase-locked to the drive's free-run timer).
    async fn cycle(
        &mut self,
        md: &MainDevice<'_>,
        group: &Group,
        cw: u16,
        target: i32,
        mode: i8,
    ) -> Result<TourSample, Box<dyn std::error::Error>> {
        let sd = group.subdevice(md, 0)?;
        {
            let mut out = sd.outputs_raw_mut();
            if let Some(o) = out.get_mut(0..7) {
                o[0..2].copy_from_slice(&cw.to_le_bytes());
                o[2..6].copy_from_slice(&target.to_le_bytes());
                o[6] = mode as u8;
            }
        }
        let clock = self.m.shared.clock();
        let since = clock.now();
        group.tx_rx(md).await?;
        self.m.shared.finish_cycle(since, CYCLE_NS);
        let inp = sd.inputs_raw();
        let b = |i: usize| inp.get(i).copied().unwrap_or(0);
        let sample = {
            let segment = self.m.shared.segment();
            let plant = &segment.drives()[0].servos[0].plant;
            TourSample {
                t_s: clock.now() as f64 * 1e-9,
                statusword: u16::from_le_bytes([b(0), b(1)]),
                position: i32::from_le_bytes([b(2), b(3), b(4), b(5)]),
                mode: b(6) as i8,
                revolutions: plant.mech_angle_rad() / TAU,
                rpm: plant.mech_speed_rad_s() / TAU * 60.0,
                iq_a: plant.currents_dq().1,
            }
        };
        self.report.samples.push(sample);
        let shown = (
            sample.statusword & (0x6F | TARGET_REACHED | BIT12 | BIT13),
            sample.mode,
        );
        if self.last != Some(shown) {
            self.last = Some(shown);
            let bits = mode_bits(sample.statusword, sample.mode);
            let line = format!(
                "   t = {:7.3} s  6041h = {:#06x}  {}{}{}  (6061h = {})",
                sample.t_s,
                sample.statusword,
                state_name(sample.statusword),
                if bits.is_empty() { "" } else { ": " },
                bits,
                sample.mode
            );
            self.report.transitions.push(line.clone());
            (self.log)(line);
        }
        Ok(sample)
    }
}

/// Position, speed and q current over the tour, one panel each, in one SVG.
pub fn plot(report: &TourReport) -> StackedPlot {
    let series = |f: &dyn Fn(&TourSample) -> f64| -> Vec<(f64, f64)> {
        report.samples.iter().map(|s| (s.t_s, f(s))).collect()
    };
    StackedPlot(vec![
        Plot::new("Position actual value 6064h", "time (s)", "revolutions")
            .size(900.0, 300.0)
            .series("6064h", &series(&|s| f64::from(s.position) / CPR)),
        Plot::new("Motor speed", "time (s)", "rpm")
            .size(900.0, 300.0)
            .series("speed", &series(&|s| s.rpm)),
        Plot::new("q current", "time (s)", "A")
            .size(900.0, 300.0)
            .series("iq", &series(&|s| s.iq_a)),
    ])
}

/// Plots drawn one below the other in one SVG.
pub struct StackedPlot(pub Vec<Plot>);

impl StackedPlot {
    /// The SVG: each plot's own SVG placed at its vertical offset.
    pub fn to_svg(&self) -> String {
        let panels: Vec<(f64, f64, String)> = self
            .0
            .iter()
            .map(|p| (p.width(), p.height(), p.to_svg()))
            .collect();
        let width = panels.iter().map(|p| p.0).fold(0.0, f64::max);
        let height: f64 = panels.iter().map(|p| p.1).sum();
        let mut out = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\">\n"
        );
        let mut y = 0.0;
        for (_, h, svg) in panels {
            // An <svg> nested in an <svg> takes x/y attributes.
            out.push_str(&svg.replacen("<svg ", &format!("<svg y=\"{y}\" "), 1));
            out.push('\n');
            y += h;
        }
        out.push_str("</svg>\n");
        out
    }

    /// Writes the SVG to `path`, creating missing parent directories.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        crate::plot::write_svg(path, &self.to_svg())
    }
}
