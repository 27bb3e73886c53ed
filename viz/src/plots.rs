//! Plots as SVG: the energy history of the relaxation (thesis Fig. 5.7) and
//! histograms of radius ratio, angles and L/d.

use std::fmt::Write as _;

use bubblemesh_core::engine::EnergySample;

use crate::geometry::Measures;
use crate::picture::xml_escape;

const KINETIC: &str = "#d62728";
const POTENTIAL: &str = "#1f77b4";
const TOTAL: &str = "#222222";
const BUBBLES: &str = "#7f7f7f";
const BAR: &str = "#6a9fd4";
const MARK: &str = "#c0392b";

/// "Nice" ticks covering [lo, hi]: about `n` multiples of 1, 2 or 5 × 10^k.
fn ticks(lo: f64, hi: f64, n: usize) -> (Vec<f64>, f64) {
    let span = if hi > lo { hi - lo } else { hi.abs().max(1.0) };
    let raw = span / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).floor() * step;
    let mut t = Vec::new();
    let mut k = 0;
    loop {
        let v = first + k as f64 * step;
        t.push(v);
        if v >= hi - 1e-9 * step || k > 50 {
            break;
        }
        k += 1;
    }
    (t, step)
}

fn tick_label(v: f64, step: f64) -> String {
    let a = v.abs();
    if a < 1e-9 * step {
        return "0".into();
    }
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        return format!("{v:.1e}");
    }
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

/// A plotting frame in pixels with data ranges.
struct Frame {
    left: f64,
    top: f64,
    w: f64,
    h: f64,
    x: (f64, f64),
    y: (f64, f64),
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        self.left + (x - self.x.0) / (self.x.1 - self.x.0) * self.w
    }
    fn py(&self, y: f64) -> f64 {
        self.top + self.h - (y - self.y.0) / (self.y.1 - self.y.0) * self.h
    }

    /// Axes, ticks, grid and labels.
    fn axes(&self, s: &mut String, xt: &(Vec<f64>, f64), yt: &(Vec<f64>, f64), xl: &str, yl: &str) {
        let _ = writeln!(
            s,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#fff" stroke="#888"/>"##,
            self.left, self.top, self.w, self.h
        );
        for &v in &xt.0 {
            let x = self.px(v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                self.top,
                self.top + self.h,
                self.top + self.h + 14.0,
                tick_label(v, xt.1)
            );
        }
        for &v in &yt.0 {
            let y = self.py(v);
            let _ = writeln!(
                s,
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#eee"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                self.left,
                self.left + self.w,
                self.left - 4.0,
                y + 4.0,
                tick_label(v, yt.1)
            );
        }
        let _ = writeln!(
            s,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#888"/>"##,
            self.left, self.top, self.w, self.h
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            self.left + 0.5 * self.w,
            self.top + self.h + 30.0,
            xml_escape(xl)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate({:.1},{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            self.left - 48.0,
            self.top + 0.5 * self.h,
            xml_escape(yl)
        );
    }
}

fn open_svg(s: &mut String, w: f64, h: f64, title: &str) {
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11" fill="#222">"##
    );
    let _ = writeln!(s, "<title>{}</title>", xml_escape(title));
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
}

/// The energy history of one face's relaxation.
#[derive(Clone, Debug)]
pub struct FaceEnergy<'a> {
    /// The face's label in the chart heading (its model name, or `face N`).
    pub name: String,
    /// The energy samples of the face's stage-2 relaxation, in step order;
    /// empty for a face that was not relaxed (stage 1 only).
    pub samples: &'a [EnergySample],
}

/// One data series of a line chart.
struct Series<'a> {
    name: &'a str,
    colour: &'a str,
    points: Vec<(f64, f64)>,
}

/// Where a line chart goes and how its axes read.
struct ChartBox<'a> {
    /// The box (left, top, width, height) in SVG units.
    left: f64,
    top: f64,
    w: f64,
    h: f64,
    /// The x range.
    x: (f64, f64),
    xlabel: &'a str,
    ylabel: &'a str,
    /// Whether the y range must include zero.
    zero: bool,
}

/// A line chart in the box with its own y range (from the data; through
/// zero when `zero`), a y label and a key on the right.
fn line_chart(s: &mut String, chart: ChartBox<'_>, series: &[Series]) {
    let ChartBox {
        left,
        top,
        w,
        h,
        x,
        xlabel,
        ylabel,
        zero,
    } = chart;
    let ys = series
        .iter()
        .flat_map(|q| q.points.iter().map(|p| p.1))
        .filter(|v| v.is_finite());
    let (mut y0, mut y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !y0.is_finite() {
        (y0, y1) = (0.0, 1.0);
    }
    if zero {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    if y1 - y0 <= 1e-12 * y1.abs().max(y0.abs()).max(f64::MIN_POSITIVE) {
        let pad = if y1 == 0.0 { 1.0 } else { 0.1 * y1.abs() };
        y0 -= pad;
        y1 += pad;
    }
    let xt = ticks(x.0, x.1, 8);
    let yt = ticks(y0, y1, 4);
    let fr = Frame {
        left,
        top,
        w,
        h,
        x: (xt.0[0], *xt.0.last().unwrap()),
        y: (yt.0[0], *yt.0.last().unwrap()),
    };
    fr.axes(s, &xt, &yt, xlabel, ylabel);
    for q in series {
        let mut pts = String::new();
        for &(px, py) in &q.points {
            if py.is_finite() {
                let _ = write!(pts, "{:.1},{:.1} ", fr.px(px), fr.py(py));
            }
        }
        let _ = writeln!(
            s,
            r#"<polyline data-series="{}" points="{}" fill="none" stroke="{}" stroke-width="1.5"{}/>"#,
            q.name,
            pts.trim_end(),
            q.colour,
            // drawn over the total, which it nearly equals once settled
            if q.name == "potential" {
                r#" stroke-dasharray="6 4""#
            } else {
                ""
            }
        );
    }
    for (i, q) in series.iter().enumerate() {
        let y = fr.top + 10.0 + 16.0 * i as f64;
        let kx = fr.left + fr.w + 12.0;
        let _ = writeln!(
            s,
            r#"<line x1="{kx:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}" stroke-width="2"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            kx + 20.0,
            q.colour,
            kx + 26.0,
            y + 4.0,
            q.name
        );
    }
}

/// The energy history of stage 2 against the time step (thesis Fig. 5.7),
/// one block per face: the kinetic energy; the potential and total energy
/// (on their own scale: the kinetic energy is orders of magnitude smaller
/// once the lattice has formed); and the number of free bubbles, which
/// population control changes. Faces without samples (stage 1 only) are
/// noted.
pub fn energy(faces: &[FaceEnergy]) -> String {
    const W: f64 = 720.0;
    const ROW: f64 = 130.0;
    const BLOCK: f64 = 28.0 + 3.0 * ROW + 10.0;
    let shown: Vec<&FaceEnergy> = faces.iter().filter(|f| !f.samples.is_empty()).collect();
    let h = 40.0 + BLOCK * shown.len().max(1) as f64;
    let mut s = String::new();
    open_svg(&mut s, W, h, "Energy history of the relaxation");
    let _ = writeln!(
        s,
        r#"<text x="12" y="20" font-size="14" font-weight="bold">Energy history of stage 2 (engine units: k0 · length²)</text>"#
    );
    if shown.is_empty() {
        let _ = writeln!(
            s,
            r#"<text x="12" y="60">no stage-2 energy history: stage 1 only (--fast), or no face was relaxed</text>"#
        );
    }
    type Field = (&'static str, &'static str, fn(&EnergySample) -> f64);
    let fields: [Field; 4] = [
        ("kinetic", KINETIC, |e| e.kinetic),
        ("potential", POTENTIAL, |e| e.potential),
        ("total", TOTAL, |e| e.total),
        ("bubbles", BUBBLES, |e| e.bubbles as f64),
    ];
    let series = |smp: &[EnergySample], k: usize| Series {
        name: fields[k].0,
        colour: fields[k].1,
        points: smp
            .iter()
            .map(|e| (e.step as f64, (fields[k].2)(e)))
            .collect(),
    };
    for (k, f) in shown.iter().enumerate() {
        let top = 40.0 + BLOCK * k as f64;
        let smp = f.samples;
        let x1 = smp.last().map_or(1.0, |e| e.step as f64).max(1.0);
        let x0 = smp.first().map_or(0.0, |e| e.step as f64).min(x1 - 1.0);
        let _ = writeln!(
            s,
            r#"<text x="72" y="{:.1}" font-size="12" font-weight="bold">{}: {} samples to step {}</text>"#,
            top + 16.0,
            xml_escape(&f.name),
            smp.len(),
            x1
        );
        let (left, w, h) = (80.0, W - 80.0 - 120.0, ROW - 40.0);
        let rows: [(&[usize], &str, bool); 3] = [
            (&[0], "kinetic", true),
            (&[2, 1], "potential, total", false),
            (&[3], "free bubbles", false),
        ];
        for (r, (which, ylabel, zero)) in rows.iter().enumerate() {
            let list: Vec<Series> = which.iter().map(|&i| series(smp, i)).collect();
            let chart = ChartBox {
                left,
                top: top + 28.0 + ROW * r as f64,
                w,
                h,
                x: (x0, x1),
                xlabel: if r == 2 { "time step" } else { "" },
                ylabel,
                zero: *zero,
            };
            line_chart(&mut s, chart, &list);
        }
    }
    let _ = writeln!(s, "</svg>");
    s
}

/// A histogram to draw.
#[derive(Clone, Debug)]
pub struct Histogram<'a> {
    /// The chart's heading, also its SVG `<title>`.
    pub title: String,
    /// The label of the horizontal axis, naming the quantity and its unit.
    pub xlabel: String,
    /// The values to count; non-finite values are left out.
    pub values: &'a [f64],
    /// The horizontal axis, `(low, high)` in the values' unit; when `high`
    /// is not above `low`, `(low, low + 1)` is used. Values outside are
    /// counted in the first or last bin (and reported).
    pub range: (f64, f64),
    /// The number of equal-width bins over `range` (0 is taken as 1).
    pub bins: usize,
    /// Vertical reference lines: position and label.
    pub markers: Vec<(f64, String)>,
}

/// A histogram as SVG: one `<rect class="bar">` per non-empty bin, with
/// the count, min, mean and max of the values.
pub fn histogram(h: &Histogram) -> String {
    const W: f64 = 640.0;
    const H: f64 = 300.0;
    let bins = h.bins.max(1);
    let (lo, hi) = if h.range.1 > h.range.0 {
        h.range
    } else {
        (h.range.0, h.range.0 + 1.0)
    };
    let mut counts = vec![0usize; bins];
    let (mut below, mut above) = (0, 0);
    let finite: Vec<f64> = h.values.iter().cloned().filter(|v| v.is_finite()).collect();
    for &v in &finite {
        let k = ((v - lo) / (hi - lo) * bins as f64).floor();
        if v < lo {
            below += 1;
        }
        if v > hi {
            above += 1;
        }
        counts[(k.max(0.0) as usize).min(bins - 1)] += 1;
    }
    let cmax = counts.iter().cloned().max().unwrap_or(0).max(1) as f64;
    let mut s = String::new();
    open_svg(&mut s, W, H, &h.title);
    let _ = writeln!(
        s,
        r#"<text x="12" y="20" font-size="14" font-weight="bold">{}</text>"#,
        xml_escape(&h.title)
    );
    let xt = ticks(lo, hi, 8);
    let yt = ticks(0.0, cmax, 5);
    let fr = Frame {
        left: 72.0,
        top: 50.0,
        w: W - 72.0 - 24.0,
        h: H - 50.0 - 46.0,
        x: (lo, hi),
        y: (0.0, *yt.0.last().unwrap()),
    };
    let xt = (
        xt.0.into_iter()
            .filter(|v| *v >= lo - 1e-9 && *v <= hi + 1e-9)
            .collect::<Vec<_>>(),
        xt.1,
    );
    fr.axes(&mut s, &xt, &yt, &h.xlabel, "count");
    let bw = (hi - lo) / bins as f64;
    for (k, &c) in counts.iter().enumerate() {
        if c == 0 {
            continue;
        }
        let (x0, x1) = (fr.px(lo + k as f64 * bw), fr.px(lo + (k + 1) as f64 * bw));
        let y = fr.py(c as f64);
        let _ = writeln!(
            s,
            r##"<rect class="bar" x="{x0:.2}" y="{y:.2}" width="{:.2}" height="{:.2}" fill="{BAR}" stroke="#fff" stroke-width="0.3" data-count="{c}"/>"##,
            (x1 - x0).max(0.5),
            fr.top + fr.h - y
        );
    }
    for (x, label) in &h.markers {
        if *x >= lo && *x <= hi {
            let px = fr.px(*x);
            let _ = writeln!(
                s,
                r#"<line x1="{px:.1}" y1="{:.1}" x2="{px:.1}" y2="{:.1}" stroke="{MARK}" stroke-dasharray="4 3"/><text x="{:.1}" y="{:.1}" fill="{MARK}">{}</text>"#,
                fr.top,
                fr.top + fr.h,
                px + 3.0,
                fr.top + 12.0,
                xml_escape(label)
            );
        }
    }
    let n = finite.len();
    let stats = if n == 0 {
        "no values".to_string()
    } else {
        let min = finite.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = finite.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let mean = finite.iter().sum::<f64>() / n as f64;
        let mut t = format!("n = {n}   min {min:.3}   mean {mean:.3}   max {max:.3}");
        if below + above > 0 {
            let _ = write!(
                t,
                "   ({} outside the axis, counted in the end bins)",
                below + above
            );
        }
        t
    };
    let _ = writeln!(s, r#"<text x="72" y="40">{}</text>"#, xml_escape(&stats));
    let _ = writeln!(s, "</svg>");
    s
}

/// The histograms of a mesh's measures: `(file stem, SVG)` for the radius
/// ratio, the triangle angles (when there are triangles) and L/d (when a
/// spacing was given).
pub fn quality_histograms(m: &Measures) -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    let what = if m.tets {
        "tetrahedra: q = 3 r_in / r_circ"
    } else {
        "triangles: q = 2 r_in / r_circ"
    };
    out.push((
        "radius_ratio",
        histogram(&Histogram {
            title: format!("Radius ratio of the {what}"),
            xlabel: "radius ratio q (1: equilateral)".into(),
            values: &m.q,
            range: (0.0, 1.0),
            bins: 50,
            markers: vec![],
        }),
    ));
    if !m.angles.is_empty() {
        out.push((
            "angles",
            histogram(&Histogram {
                title: "Angles of the triangles (every angle)".into(),
                xlabel: "angle (degrees)".into(),
                values: &m.angles,
                range: (0.0, 180.0),
                bins: 90,
                markers: vec![(60.0, "60°".into())],
            }),
        ));
    }
    if !m.length_ratio.is_empty() {
        let max = m.length_ratio.iter().cloned().fold(0.0, f64::max);
        let hi = (max * 10.0).ceil() / 10.0;
        out.push((
            "length_ratio",
            histogram(&Histogram {
                title: "Edge length over spacing, L / d(midpoint)".into(),
                xlabel: "L / d".into(),
                values: &m.length_ratio,
                range: (0.0, hi.clamp(1.5, 3.0)),
                bins: 60,
                markers: vec![
                    (1.0, "1".into()),
                    (std::f64::consts::FRAC_1_SQRT_2, "1/√2".into()),
                    (std::f64::consts::SQRT_2, "√2".into()),
                ],
            }),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let (t, step) = ticks(0.0, 0.93, 5);
        assert_eq!(step, 0.2);
        assert_eq!(t.first(), Some(&0.0));
        assert!(*t.last().unwrap() >= 0.93);
        let (t, _) = ticks(3.0, 597.0, 8);
        assert!(t[0] <= 3.0 && *t.last().unwrap() >= 597.0);
        assert_eq!(tick_label(0.4, 0.2), "0.4");
        assert_eq!(tick_label(200.0, 100.0), "200");
    }
}
