//! Small, dependency-free SVG charts for the HTML report.
//!
//! The report must be one self-contained page that opens without network or
//! system fonts, so the charts are written as plain SVG text: line charts
//! (several series, optional log scale), grouped bar charts, heat maps over
//! a regular grid and scatter maps of a scalar at scattered points. Every chart has a title, labelled axes with "nice" ticks and
//! a legend where there is more than one series.

use std::fmt::Write;

/// Width of every chart, in SVG user units (pixels).
const WIDTH: f64 = 720.0;
/// Height of every chart, in SVG user units (pixels).
const HEIGHT: f64 = 360.0;
const MARGIN_LEFT: f64 = 72.0;
const MARGIN_RIGHT: f64 = 210.0;
const MARGIN_TOP: f64 = 36.0;
const MARGIN_BOTTOM: f64 = 52.0;

/// Colours of successive series (colour-blind friendly palette).
const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
];

/// One named series of a line chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points (x, y); non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw markers at the points as well as the line.
    pub markers: bool,
    /// Dashed line (e.g. for targets or references).
    pub dashed: bool,
}

impl Series {
    /// A solid line with markers.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: true,
            dashed: false,
        }
    }

    /// The same series drawn dashed without markers.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self.markers = false;
        self
    }
}

/// `text` cut to at most `max` characters, with an ellipsis when cut.
fn shorten(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        text.to_string()
    } else {
        let mut s: String = text.chars().take(max - 1).collect();
        s.push('…');
        s
    }
}

/// Escapes text for inclusion in SVG/HTML.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Tick positions covering [lo, hi] with a "nice" step (1, 2 or 5 times a power of ten).
fn nice_ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step).ceil() * step;
    let mut ticks = Vec::new();
    let mut t = first;
    while t <= hi + step * 1e-9 {
        ticks.push(if t.abs() < step * 1e-9 { 0.0 } else { t });
        t += step;
    }
    ticks
}

fn format_tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Range of finite values, padded by 5 % (or by 1 when flat).
fn padded_range(values: impl Iterator<Item = f64>, include_zero: bool) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if include_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if hi - lo < 1e-300 {
        return (lo - 1.0, hi + 1.0);
    }
    let pad = 0.05 * (hi - lo);
    (
        if include_zero && lo == 0.0 {
            0.0
        } else {
            lo - pad
        },
        hi + pad,
    )
}

struct Frame {
    x_lo: f64,
    x_hi: f64,
    y_lo: f64,
    y_hi: f64,
    log_y: bool,
}

impl Frame {
    fn plot_width() -> f64 {
        WIDTH - MARGIN_LEFT - MARGIN_RIGHT
    }
    fn plot_height() -> f64 {
        HEIGHT - MARGIN_TOP - MARGIN_BOTTOM
    }
    fn px(&self, x: f64) -> f64 {
        MARGIN_LEFT + (x - self.x_lo) / (self.x_hi - self.x_lo) * Self::plot_width()
    }
    fn py(&self, y: f64) -> f64 {
        let (v, lo, hi) = if self.log_y {
            (y.log10(), self.y_lo.log10(), self.y_hi.log10())
        } else {
            (y, self.y_lo, self.y_hi)
        };
        MARGIN_TOP + (1.0 - (v - lo) / (hi - lo)) * Self::plot_height()
    }
}

fn open_svg(out: &mut String, title: &str) {
    let _ = write!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {WIDTH} {HEIGHT}" width="{WIDTH}" height="{HEIGHT}" role="img" aria-label="{t}" font-family="sans-serif" font-size="12"><title>{t}</title><rect width="100%" height="100%" fill="white"/><text x="{cx}" y="20" text-anchor="middle" font-size="14" font-weight="bold">{t}</text>"#,
        t = escape(title),
        cx = WIDTH / 2.0
    );
}

fn axes(out: &mut String, frame: &Frame, x_label: &str, y_label: &str, x_ticks: &[(f64, String)]) {
    let (x0, x1) = (MARGIN_LEFT, WIDTH - MARGIN_RIGHT);
    let (y0, y1) = (HEIGHT - MARGIN_BOTTOM, MARGIN_TOP);
    let _ = write!(
        out,
        r##"<rect x="{x0}" y="{y1}" width="{w}" height="{h}" fill="none" stroke="#444"/>"##,
        w = x1 - x0,
        h = y0 - y1
    );
    for (x, label) in x_ticks {
        let px = frame.px(*x);
        let _ = write!(
            out,
            r##"<line x1="{px:.1}" y1="{y0}" x2="{px:.1}" y2="{y1}" stroke="#ddd"/><text x="{px:.1}" y="{ty}" text-anchor="middle">{l}</text>"##,
            ty = y0 + 16.0,
            l = escape(label)
        );
    }
    let y_ticks: Vec<f64> = if frame.log_y {
        let lo = frame.y_lo.log10().floor() as i32;
        let hi = frame.y_hi.log10().ceil() as i32;
        (lo..=hi)
            .map(|e| 10f64.powi(e))
            .filter(|v| *v >= frame.y_lo * 0.999 && *v <= frame.y_hi * 1.001)
            .collect()
    } else {
        nice_ticks(frame.y_lo, frame.y_hi, 6)
    };
    for y in y_ticks {
        let py = frame.py(y);
        let _ = write!(
            out,
            r##"<line x1="{x0}" y1="{py:.1}" x2="{x1}" y2="{py:.1}" stroke="#ddd"/><text x="{tx}" y="{ty:.1}" text-anchor="end">{l}</text>"##,
            tx = x0 - 6.0,
            ty = py + 4.0,
            l = format_tick(y)
        );
    }
    let _ = write!(
        out,
        r#"<text x="{cx}" y="{by}" text-anchor="middle">{xl}</text><text transform="translate(16 {cy}) rotate(-90)" text-anchor="middle">{yl}</text>"#,
        cx = (x0 + x1) / 2.0,
        by = HEIGHT - 12.0,
        xl = escape(x_label),
        cy = (y0 + y1) / 2.0,
        yl = escape(y_label)
    );
}

fn legend(out: &mut String, labels: &[(String, &str, bool)]) {
    let x = WIDTH - MARGIN_RIGHT + 12.0;
    for (i, (label, colour, dashed)) in labels.iter().enumerate() {
        let y = MARGIN_TOP + 10.0 + 18.0 * i as f64;
        let dash = if *dashed {
            r#" stroke-dasharray="5 3""#
        } else {
            ""
        };
        let _ = write!(
            out,
            r#"<line x1="{x}" y1="{y}" x2="{x2}" y2="{y}" stroke="{colour}" stroke-width="2"{dash}/><text x="{tx}" y="{ty}">{l}</text>"#,
            x2 = x + 18.0,
            tx = x + 24.0,
            ty = y + 4.0,
            l = escape(&shorten(label, 30))
        );
    }
}

/// The scale of a chart's y axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum YScale {
    /// Linear.
    Linear,
    /// Logarithmic (decades); non-positive values are skipped.
    Log,
}

/// The padded range of the values of a y axis, whole decades apart on a
/// log axis (`values` are then positive).
fn y_range(values: impl Iterator<Item = f64>, log_y: bool, include_zero: bool) -> (f64, f64) {
    if log_y {
        let (lo, hi) = padded_range(values.map(f64::log10), false);
        (10f64.powf(lo), 10f64.powf(hi))
    } else {
        padded_range(values, include_zero)
    }
}

/// Starts a chart with numeric axes over `frame`.
fn open_chart(title: &str, frame: &Frame, x_label: &str, y_label: &str) -> String {
    let mut out = String::new();
    open_svg(&mut out, title);
    let x_ticks: Vec<(f64, String)> = nice_ticks(frame.x_lo, frame.x_hi, 8)
        .into_iter()
        .map(|t| (t, format_tick(t)))
        .collect();
    axes(&mut out, frame, x_label, y_label, &x_ticks);
    out
}

/// Ends a chart of `n_series` series: the legend when there are several.
fn close_chart(mut out: String, labels: &[(String, &str, bool)], n_series: usize) -> String {
    if n_series > 1 {
        legend(&mut out, labels);
    }
    out.push_str("</svg>");
    out
}

/// A line chart of several series. On a log scale, non-positive values are skipped.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    y_scale: YScale,
) -> String {
    let log_y = y_scale == YScale::Log;
    let usable = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && (!log_y || y > 0.0);
    let all = || {
        series
            .iter()
            .flat_map(|s| s.points.iter().copied().filter(usable))
    };
    let (x_lo, x_hi) = padded_range(all().map(|p| p.0), false);
    let (y_lo, y_hi) = y_range(all().map(|p| p.1), log_y, false);
    let frame = Frame {
        x_lo,
        x_hi,
        y_lo,
        y_hi,
        log_y,
    };
    let mut out = open_chart(title, &frame, x_label, y_label);
    let mut labels = Vec::new();
    for (i, s) in series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(usable)
            .map(|(x, y)| (frame.px(x), frame.py(y)))
            .collect();
        if pts.len() > 1 {
            let path: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
            let dash = if s.dashed {
                r#" stroke-dasharray="5 3""#
            } else {
                ""
            };
            let _ = write!(
                out,
                r#"<polyline fill="none" stroke="{colour}" stroke-width="1.8"{dash} points="{}"/>"#,
                path.join(" ")
            );
        }
        if s.markers || pts.len() == 1 {
            for (x, y) in &pts {
                let _ = write!(
                    out,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="2.6" fill="{colour}"/>"#
                );
            }
        }
        labels.push((s.label.clone(), colour, s.dashed));
    }
    close_chart(out, &labels, series.len())
}

/// A grouped bar chart: one group per category, one bar per series in each
/// group. `values[s][c]` is the value of series `s` in category `c`.
pub fn bar_chart(
    title: &str,
    y_label: &str,
    categories: &[String],
    series_labels: &[String],
    values: &[Vec<f64>],
    y_scale: YScale,
) -> String {
    let log_y = y_scale == YScale::Log;
    let finite = values
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite() && (!log_y || *v > 0.0));
    let (y_lo, y_hi) = y_range(finite, log_y, true);
    let n_cat = categories.len().max(1);
    let frame = Frame {
        x_lo: 0.0,
        x_hi: n_cat as f64,
        y_lo,
        y_hi,
        log_y,
    };
    let mut out = String::new();
    open_svg(&mut out, title);
    // Category labels are drawn rotated below the axis when there are many.
    let rotate = n_cat > 8;
    let ticks: Vec<(f64, String)> = if rotate {
        Vec::new()
    } else {
        categories
            .iter()
            .enumerate()
            .map(|(i, c)| (i as f64 + 0.5, c.clone()))
            .collect()
    };
    axes(&mut out, &frame, "", y_label, &ticks);
    if rotate {
        for (i, c) in categories.iter().enumerate() {
            let px = frame.px(i as f64 + 0.5);
            let _ = write!(
                out,
                r#"<text transform="translate({px:.1} {y}) rotate(-60)" text-anchor="end" font-size="9">{l}</text>"#,
                y = HEIGHT - MARGIN_BOTTOM + 8.0,
                l = escape(c)
            );
        }
    }
    let n_series = values.len().max(1);
    let group_width = 0.8 / n_series as f64;
    let base = if log_y { y_lo } else { 0.0f64.max(y_lo) };
    let mut labels = Vec::new();
    for (s, row) in values.iter().enumerate() {
        let colour = PALETTE[s % PALETTE.len()];
        for (c, v) in row.iter().enumerate() {
            if !v.is_finite() || (log_y && *v <= 0.0) {
                continue;
            }
            let x = frame.px(c as f64 + 0.1 + group_width * s as f64);
            let w = frame.px(group_width) - frame.px(0.0);
            let (ya, yb) = (frame.py(*v), frame.py(base));
            let _ = write!(
                out,
                r#"<rect x="{x:.1}" y="{:.1}" width="{w:.1}" height="{:.1}" fill="{colour}"><title>{}: {}</title></rect>"#,
                ya.min(yb),
                (ya - yb).abs(),
                escape(categories.get(c).map(String::as_str).unwrap_or("")),
                format_tick(*v)
            );
        }
        labels.push((
            series_labels.get(s).cloned().unwrap_or_default(),
            colour,
            false,
        ));
    }
    close_chart(out, &labels, values.len())
}

/// A heat map of a scalar over a regular grid: `values[row][col]` at
/// (`xs[col]`, `ys[row]`), coloured from light to dark with a colour bar.
pub fn heat_map(
    title: &str,
    x_label: &str,
    y_label: &str,
    xs: &[f64],
    ys: &[f64],
    values: &[Vec<f64>],
    unit: &str,
) -> String {
    let (x_lo, x_hi) = padded_range(xs.iter().copied(), false);
    let (y_lo, y_hi) = padded_range(ys.iter().copied(), false);
    let frame = Frame {
        x_lo,
        x_hi,
        y_lo,
        y_hi,
        log_y: false,
    };
    let scale = ColourScale::over(values.iter().flatten().copied());
    let mut out = open_chart(title, &frame, x_label, y_label);
    let half = |v: &[f64], i: usize| -> (f64, f64) {
        let left = if i > 0 {
            (v[i] - v[i - 1]) / 2.0
        } else if v.len() > 1 {
            (v[1] - v[0]) / 2.0
        } else {
            0.5
        };
        let right = if i + 1 < v.len() {
            (v[i + 1] - v[i]) / 2.0
        } else {
            left
        };
        (v[i] - left.abs(), v[i] + right.abs())
    };
    for (r, row) in values.iter().enumerate().take(ys.len()) {
        for (c, v) in row.iter().enumerate().take(xs.len()) {
            if !v.is_finite() {
                continue;
            }
            let (xa, xb) = half(xs, c);
            let (ya, yb) = half(ys, r);
            let (px0, px1) = (frame.px(xa), frame.px(xb));
            let (py0, py1) = (frame.py(yb), frame.py(ya));
            let _ = write!(
                out,
                r#"<rect x="{px0:.1}" y="{py0:.1}" width="{:.1}" height="{:.1}" fill="{}"><title>({}, {}): {} {}</title></rect>"#,
                (px1 - px0).abs(),
                (py1 - py0).abs(),
                scale.colour(*v),
                format_tick(xs[c]),
                format_tick(ys[r]),
                format_tick(*v),
                escape(unit)
            );
        }
    }
    scale.bar(&mut out, unit);
    out.push_str("</svg>");
    out
}

/// A scatter plot of points `(x, y, value)` coloured by their value, with a
/// colour bar: a scalar known at scattered places (a workspace grid seen
/// from one side).
pub fn scatter_map(
    title: &str,
    x_label: &str,
    y_label: &str,
    points: &[(f64, f64, f64)],
    unit: &str,
) -> String {
    let finite: Vec<&(f64, f64, f64)> = points
        .iter()
        .filter(|(x, y, v)| x.is_finite() && y.is_finite() && v.is_finite())
        .collect();
    let (x_lo, x_hi) = padded_range(finite.iter().map(|p| p.0), false);
    let (y_lo, y_hi) = padded_range(finite.iter().map(|p| p.1), false);
    let frame = Frame {
        x_lo,
        x_hi,
        y_lo,
        y_hi,
        log_y: false,
    };
    let scale = ColourScale::over(finite.iter().map(|p| p.2));
    let mut out = open_chart(title, &frame, x_label, y_label);
    // The largest values last, so that they stay visible where points overlap.
    let mut order: Vec<&(f64, f64, f64)> = finite;
    order.sort_by(|a, b| a.2.total_cmp(&b.2));
    for (x, y, v) in order {
        let _ = write!(
            out,
            r##"<circle cx="{:.1}" cy="{:.1}" r="3.2" fill="{}" stroke="#666" stroke-width="0.3"><title>({}, {}): {} {}</title></circle>"##,
            frame.px(*x),
            frame.py(*y),
            scale.colour(*v),
            format_tick(*x),
            format_tick(*y),
            format_tick(*v),
            escape(unit)
        );
    }
    scale.bar(&mut out, unit);
    out.push_str("</svg>");
    out
}

/// The colours of a scalar from its smallest to its largest finite value,
/// pale yellow to dark blue.
struct ColourScale {
    lo: f64,
    hi: f64,
}

impl ColourScale {
    fn over(values: impl Iterator<Item = f64>) -> Self {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo.is_finite() {
            Self { lo, hi }
        } else {
            Self { lo: 0.0, hi: 1.0 }
        }
    }

    fn span(&self) -> f64 {
        (self.hi - self.lo).max(1e-300)
    }

    fn colour(&self, v: f64) -> String {
        let t = ((v - self.lo) / self.span()).clamp(0.0, 1.0);
        let (r, g, b) = (
            255.0 + t * (8.0 - 255.0),
            247.0 + t * (48.0 - 247.0),
            188.0 + t * (107.0 - 188.0),
        );
        format!("rgb({:.0},{:.0},{:.0})", r, g, b)
    }

    /// The colour bar right of the plot, labelled with the extremes.
    fn bar(&self, out: &mut String, unit: &str) {
        let bx = WIDTH - MARGIN_RIGHT + 20.0;
        let steps = 20;
        let bar_h = Frame::plot_height();
        for i in 0..steps {
            let t0 = i as f64 / steps as f64;
            let y = MARGIN_TOP + (1.0 - t0 - 1.0 / steps as f64) * bar_h;
            let _ = write!(
                out,
                r#"<rect x="{bx}" y="{y:.1}" width="16" height="{:.1}" fill="{}"/>"#,
                bar_h / steps as f64 + 0.5,
                self.colour(self.lo + t0 * self.span())
            );
        }
        let _ = write!(
            out,
            r#"<text x="{tx}" y="{t1}">{hi} {u}</text><text x="{tx}" y="{t2}">{lo} {u}</text>"#,
            tx = bx + 22.0,
            t1 = MARGIN_TOP + 10.0,
            t2 = MARGIN_TOP + bar_h,
            hi = format_tick(self.hi),
            lo = format_tick(self.lo),
            u = escape(unit)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn well_formed(svg: &str) {
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        assert_eq!(svg.matches("<svg").count(), 1);
    }

    #[test]
    fn ticks_are_nice_and_cover_the_range() {
        let t = nice_ticks(0.13, 0.97, 5);
        assert_eq!(t, vec![0.2, 0.4, 0.6000000000000001, 0.8]);
        let t = nice_ticks(-3.0, 12.0, 5);
        assert!(t.contains(&0.0) && t.contains(&10.0));
    }

    #[test]
    fn charts_escape_text_and_skip_non_finite_values() {
        let s = line_chart(
            "a < b & c",
            "x",
            "y",
            &[
                Series::new("one", vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0)]),
                Series::new("two", vec![(0.0, 0.5), (2.0, 0.25)]).dashed(),
            ],
            YScale::Log,
        );
        well_formed(&s);
        assert!(s.contains("a &lt; b &amp; c"));
        let b = bar_chart(
            "bars",
            "mm",
            &["300".into(), "600".into()],
            &["fe".into(), "fuzzy".into()],
            &[vec![0.1, 0.2], vec![0.05, f64::INFINITY]],
            YScale::Linear,
        );
        well_formed(&b);
        assert_eq!(b.matches("<rect x=").count(), 3 + 1);
        let h = heat_map(
            "map",
            "x",
            "z",
            &[1.0, 2.0, 3.0],
            &[0.0, 1.0],
            &[vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]],
            "mm",
        );
        well_formed(&h);
        let m = scatter_map(
            "bounds",
            "x",
            "y",
            &[(0.0, 1.0, 0.1), (1.0, 0.0, 0.3), (f64::NAN, 0.0, 1.0)],
            "mm",
        );
        well_formed(&m);
        assert_eq!(m.matches("<circle").count(), 2);
        assert!(m.contains("0.3 mm") && m.contains("0.1 mm"));
    }
}
