//! A tiny SVG line-plot writer (no dependencies), for test and benchmark reports: several
//! series with distinct colours and a legend, optional horizontal reference lines, linear or
//! logarithmic x axis, rounded tick values and grid lines.
//!
//! ```no_run
//! use board_sim::plot::Plot;
//! Plot::new("Step response", "t [s]", "i_q [A]")
//!     .series("measured", &[(0.0, 0.0), (1e-3, 4.0), (2e-3, 5.0)])
//!     .hline(5.0, "reference")
//!     .write("target/plots/step.svg")
//!     .expect("write plot");
//! ```
//!
//! Points with a non-finite coordinate (and, on a log axis, with `x <= 0`) are skipped.

use std::fmt::Write as _;
use std::path::Path;

/// Default image size in px.
const DEFAULT_WIDTH: f64 = 800.0;
const DEFAULT_HEIGHT: f64 = 500.0;
/// Margins around the plot area in px (the right one holds the legend).
const MARGIN_LEFT: f64 = 80.0;
const MARGIN_RIGHT: f64 = 190.0;
const MARGIN_TOP: f64 = 45.0;
const MARGIN_BOTTOM: f64 = 60.0;
/// Vertical distance between legend entries, px.
const LEGEND_LINE_PX: f64 = 20.0;
/// Target number of tick intervals on a linear axis.
const TARGET_TICKS: f64 = 6.0;
/// Relative padding of a degenerate (zero-width) data range.
const DEGENERATE_PAD: f64 = 0.1;
/// Series colours (Tableau 10), reused cyclically.
const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// A line plot under construction (builder style).
#[derive(Debug, Clone, PartialEq)]
pub struct Plot {
    title: String,
    x_label: String,
    y_label: String,
    log_x: bool,
    width: f64,
    height: f64,
    series: Vec<(String, Vec<(f64, f64)>)>,
    hlines: Vec<(f64, String)>,
}

/// One axis: data-space range after rounding to ticks, and the ticks (value, label).
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    major: Vec<(f64, String)>,
    minor: Vec<f64>,
}

impl Axis {
    /// Position of `v` in [0, 1] along the axis.
    fn frac(&self, v: f64) -> f64 {
        let t = |x: f64| if self.log { x.log10() } else { x };
        (t(v) - t(self.lo)) / (t(self.hi) - t(self.lo))
    }

    fn linear(min: f64, max: f64) -> Axis {
        let (min, max) = padded(min, max);
        let step = nice_step((max - min) / TARGET_TICKS);
        let first = (min / step).floor();
        let last = (max / step).ceil();
        let count = (last - first) as i64;
        let major = (0..=count)
            .map(|k| {
                let v = (first + k as f64) * step;
                (v, format_tick(v, step))
            })
            .collect();
        Axis {
            lo: first * step,
            hi: last * step,
            log: false,
            major,
            minor: Vec::new(),
        }
    }

    fn logarithmic(min: f64, max: f64) -> Axis {
        let lo = min.log10().floor() as i32;
        let mut hi = max.log10().ceil() as i32;
        if hi <= lo {
            hi = lo + 1;
        }
        let major = (lo..=hi)
            .map(|k| (10f64.powi(k), format_decade(k)))
            .collect();
        let minor = (lo..hi)
            .flat_map(|k| (2..10).map(move |m| f64::from(m) * 10f64.powi(k)))
            .collect();
        Axis {
            lo: 10f64.powi(lo),
            hi: 10f64.powi(hi),
            log: true,
            major,
            minor,
        }
    }
}

/// A zero-width range widened so that it can be drawn.
fn padded(min: f64, max: f64) -> (f64, f64) {
    if max > min {
        (min, max)
    } else {
        let pad = if min == 0.0 {
            1.0
        } else {
            min.abs() * DEGENERATE_PAD
        };
        (min - pad, max + pad)
    }
}

/// The 1-2-5 series value nearest to `raw` (switching at the geometric-ish midpoints).
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let nice = if norm < 1.5 {
        1.0
    } else if norm < 3.5 {
        2.0
    } else if norm < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * mag
}

/// Tick label with as many decimals as the step needs (exponent form for extreme values).
fn format_tick(v: f64, step: f64) -> String {
    // Values within rounding noise of zero print as 0, never as "-0".
    if v.abs() < step * 1e-9 {
        return "0".to_string();
    }
    let big = v.abs() >= 1e6;
    let small = step < 1e-4;
    if big || small {
        return format!("{v:e}");
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// Label of the decade `10^k`.
fn format_decade(k: i32) -> String {
    if (-3..=4).contains(&k) {
        let v = 10f64.powi(k);
        let decimals = (-k).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("1e{k}")
    }
}

/// Escapes text for SVG/XML content and attributes.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

impl Plot {
    /// An empty plot with a title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Plot {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            log_x: false,
            width: DEFAULT_WIDTH,
            height: DEFAULT_HEIGHT,
            series: Vec::new(),
            hlines: Vec::new(),
        }
    }

    /// Logarithmic x axis (decade ticks; points with `x <= 0` are skipped).
    pub fn log_x(mut self) -> Self {
        self.log_x = true;
        self
    }

    /// Image size in px (defaults 800 × 500; values below the margins are raised).
    pub fn size(mut self, width: f64, height: f64) -> Self {
        let min_w = MARGIN_LEFT + MARGIN_RIGHT + 1.0;
        let min_h = MARGIN_TOP + MARGIN_BOTTOM + 1.0;
        self.width = if width.is_finite() {
            width.max(min_w)
        } else {
            min_w
        };
        self.height = if height.is_finite() {
            height.max(min_h)
        } else {
            min_h
        };
        self
    }

    /// Image width in px.
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Image height in px.
    pub fn height(&self) -> f64 {
        self.height
    }

    /// Adds a named series (drawn as one polyline, next colour of the palette).
    pub fn series(mut self, name: &str, points: &[(f64, f64)]) -> Self {
        self.series.push((name.to_string(), points.to_vec()));
        self
    }

    /// Adds a dashed horizontal reference line at `y` with a label.
    pub fn hline(mut self, y: f64, label: &str) -> Self {
        if y.is_finite() {
            self.hlines.push((y, label.to_string()));
        }
        self
    }

    fn usable(&self, &(x, y): &(f64, f64)) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0)
    }

    fn axes(&self) -> (Axis, Axis) {
        let pts = self.series.iter().flat_map(|(_, p)| p.iter());
        let (mut xmin, mut xmax, mut ymin, mut ymax) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in pts.filter(|p| self.usable(p)) {
            xmin = xmin.min(p.0);
            xmax = xmax.max(p.0);
            ymin = ymin.min(p.1);
            ymax = ymax.max(p.1);
        }
        for &(y, _) in &self.hlines {
            ymin = ymin.min(y);
            ymax = ymax.max(y);
        }
        if xmin > xmax {
            // No usable x data: a unit range (1..10 on a log axis).
            (xmin, xmax) = if self.log_x { (1.0, 10.0) } else { (0.0, 1.0) };
        }
        if ymin > ymax {
            (ymin, ymax) = (0.0, 1.0);
        }
        let x = if self.log_x {
            Axis::logarithmic(xmin, xmax)
        } else {
            Axis::linear(xmin, xmax)
        };
        (x, Axis::linear(ymin, ymax))
    }

    /// Renders the plot as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        let (xa, ya) = self.axes();
        let (w, h) = (self.width, self.height);
        let pw = w - MARGIN_LEFT - MARGIN_RIGHT;
        let ph = h - MARGIN_TOP - MARGIN_BOTTOM;
        let sx = |x: f64| MARGIN_LEFT + xa.frac(x) * pw;
        let sy = |y: f64| MARGIN_TOP + (1.0 - ya.frac(y)) * ph;
        let (left, right, top, bottom) =
            (MARGIN_LEFT, MARGIN_LEFT + pw, MARGIN_TOP, MARGIN_TOP + ph);

        let mut s = String::new();
        // `write!` into a String cannot fail; the results are ignored deliberately.
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="25" text-anchor="middle" font-size="16">{}</text>"#,
            left + pw / 2.0,
            escape(&self.title)
        );
        // Grid and ticks.
        for &v in &xa.minor {
            let x = sx(v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.2}" y1="{top}" x2="{x:.2}" y2="{bottom}" stroke="#f0f0f0"/>"##
            );
        }
        for (v, label) in &xa.major {
            let x = sx(*v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.2}" y1="{top}" x2="{x:.2}" y2="{bottom}" stroke="#d8d8d8"/>"##
            );
            let _ = writeln!(
                s,
                r#"<text x="{x:.2}" y="{:.1}" text-anchor="middle">{}</text>"#,
                bottom + 18.0,
                escape(label)
            );
        }
        for (v, label) in &ya.major {
            let y = sy(*v);
            let _ = writeln!(
                s,
                r##"<line x1="{left}" y1="{y:.2}" x2="{right}" y2="{y:.2}" stroke="#d8d8d8"/>"##
            );
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.2}" text-anchor="end">{}</text>"#,
                left - 6.0,
                y + 4.0,
                escape(label)
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
        );
        // Axis labels.
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            left + pw / 2.0,
            h - 15.0,
            escape(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text x="20" y="{0:.1}" text-anchor="middle" transform="rotate(-90 20 {0:.1})">{1}</text>"#,
            top + ph / 2.0,
            escape(&self.y_label)
        );
        // Reference lines.
        for (y, label) in &self.hlines {
            let y = sy(*y);
            let _ = writeln!(
                s,
                r##"<line x1="{left}" y1="{y:.2}" x2="{right}" y2="{y:.2}" stroke="#444" stroke-dasharray="6 4"/>"##
            );
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{:.2}" text-anchor="end" fill="#444">{}</text>"##,
                right - 4.0,
                y - 4.0,
                escape(label)
            );
        }
        // Series and legend.
        for (k, (name, points)) in self.series.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let mut coords = String::new();
            for p in points.iter().filter(|p| self.usable(p)) {
                if !coords.is_empty() {
                    coords.push(' ');
                }
                let _ = write!(coords, "{:.2},{:.2}", sx(p.0), sy(p.1));
            }
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{colour}" stroke-width="1.5" points="{coords}"/>"#
            );
            let ly = top + 10.0 + k as f64 * LEGEND_LINE_PX;
            let lx = right + 15.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{:.1}" y2="{ly}" stroke="{colour}" stroke-width="2"/>"#,
                lx + 25.0
            );
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                lx + 32.0,
                ly + 4.0,
                escape(name)
            );
        }
        s.push_str("</svg>\n");
        s
    }

    /// Writes the SVG to `path`, creating missing parent directories.
    pub fn write(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        write_svg(path.as_ref(), &self.to_svg())
    }
}

/// Writes `svg` to `path`, creating missing parent directories.
pub fn write_svg(path: &Path, svg: &str) -> std::io::Result<()> {
    if let Some(parent) = path.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent)?;
        }
    }
    std::fs::write(path, svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Point counts of every `<polyline>`, in order.
    fn polyline_point_counts(svg: &str) -> Vec<usize> {
        svg.lines()
            .filter(|l| l.starts_with("<polyline"))
            .map(|l| {
                let start = l.find("points=\"").expect("points attribute") + "points=\"".len();
                let end = start + l[start..].find('"').expect("closing quote");
                l[start..end].split_whitespace().count()
            })
            .collect()
    }

    #[test]
    fn svg_has_one_polyline_per_series_with_all_points() {
        let a: Vec<(f64, f64)> = (0..50).map(|k| (k as f64, (k as f64).sin())).collect();
        let b = [(0.0, 1.0), (f64::NAN, 2.0), (3.0, 0.5)];
        let svg = Plot::new("t", "x", "y")
            .series("a", &a)
            .series("b", &b)
            .hline(0.25, "ref")
            .to_svg();
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(polyline_point_counts(&svg), vec![50, 2]);
        // Distinct colours, a dashed reference line and both legend names.
        assert!(svg.contains(PALETTE[0]) && svg.contains(PALETTE[1]));
        assert!(svg.contains("stroke-dasharray") && svg.contains(">ref<"));
        assert!(svg.contains(">a<") && svg.contains(">b<"));
        // Balanced tags: every opened element is self-closed or closed.
        assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
    }

    #[test]
    fn labels_are_escaped() {
        let svg = Plot::new("a<b & c>d", "x \"q\"", "y")
            .series("i<sub>q</sub>", &[(0.0, 0.0), (1.0, 1.0)])
            .to_svg();
        assert!(svg.contains("a&lt;b &amp; c&gt;d"));
        assert!(svg.contains("x &quot;q&quot;"));
        assert!(svg.contains("i&lt;sub&gt;q&lt;/sub&gt;"));
        assert!(!svg.contains("<sub>"));
    }

    #[test]
    fn linear_ticks_are_rounded() {
        let svg = Plot::new("t", "x", "y")
            .series("s", &[(0.0, 0.0), (7.3, 0.013)])
            .to_svg();
        for label in [">0<", ">2<", ">4<", ">6<", ">8<", ">0.002<", ">0.014<"] {
            assert!(svg.contains(label), "missing tick {label}");
        }
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b;
        assert!(close(nice_step(0.13), 0.1));
        assert!(close(nice_step(0.3), 0.2));
        assert!(close(nice_step(4.0), 5.0));
        assert!(close(nice_step(8.0), 10.0));
        assert_eq!(format_tick(-1e-17, 0.1), "0");
    }

    #[test]
    fn log_x_has_decade_ticks_and_skips_non_positive_x() {
        let pts: Vec<(f64, f64)> = (0..=30)
            .map(|k| (10f64.powf(1.0 + k as f64 / 10.0), k as f64))
            .chain([(0.0, 1.0), (-5.0, 1.0)])
            .collect();
        let svg = Plot::new("bode", "f [Hz]", "dB")
            .log_x()
            .series("g", &pts)
            .to_svg();
        for label in [">10<", ">100<", ">1000<", ">10000<"] {
            assert!(svg.contains(label), "missing decade {label}");
        }
        assert_eq!(polyline_point_counts(&svg), vec![31]);
        assert_eq!(format_decade(-3), "0.001");
        assert_eq!(format_decade(6), "1e6");
    }

    #[test]
    fn empty_and_degenerate_plots_render() {
        let svg = Plot::new("empty", "x", "y").to_svg();
        assert!(svg.starts_with("<svg") && !svg.contains("NaN") && !svg.contains("inf"));
        let svg = Plot::new("flat", "x", "y")
            .series("c", &[(1.0, 5.0), (1.0, 5.0)])
            .to_svg();
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
        assert_eq!(polyline_point_counts(&svg), vec![2]);
    }

    #[test]
    fn write_creates_parent_directories() {
        let dir = std::env::temp_dir().join(format!("plot-test-{}", std::process::id()));
        let path = dir.join("nested").join("p.svg");
        Plot::new("t", "x", "y")
            .series("s", &[(0.0, 1.0), (1.0, 2.0)])
            .write(&path)
            .expect("write");
        let text = std::fs::read_to_string(&path).expect("read back");
        assert!(text.starts_with("<svg"));
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
