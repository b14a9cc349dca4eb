//! Charts: a small declarative description drawn with plotters into inline
//! SVG whose parts can be found.
//!
//! Plotters draws primitives only (`<line>`, `<polyline>`, `<circle>`...).
//! To make a chart testable, every logical part (title, axes, axis labels,
//! each data layer, the legend and its entries) is wrapped in a `<g>` with a
//! class and `data-*` attributes. The drawing backend is this crate's
//! [`SvgCanvas`]: group boundaries are plotters elements drawn between the
//! parts, and the canvas writes the `<g>` elements, the root `<svg>` and its
//! `<title>` itself (see [`crate::svg`]).
//!
//! Data are mapped to pixels here rather than by plotters so that long
//! records can be reduced to a min/max envelope per pixel column (peaks
//! survive), non-finite values are skipped and values a log axis cannot show
//! are clamped, each with a note for the caption.

use std::collections::BTreeSet;
use std::ops::Range;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::ReportError;
use crate::format::{power_of_ten, trim};
use crate::svg::{FONT_SCALE, Group, GroupMark, SvgCanvas, SvgError};

/// An RGB colour.
pub type Rgb = (u8, u8, u8);

/// Colour-blind-safe palette (Okabe and Ito).
pub mod palette {
    use super::Rgb;
    pub const BLUE: Rgb = (0x00, 0x72, 0xB2);
    pub const VERMILLION: Rgb = (0xD5, 0x5E, 0x00);
    pub const GREEN: Rgb = (0x00, 0x9E, 0x73);
    pub const ORANGE: Rgb = (0xE6, 0x9F, 0x00);
    pub const PURPLE: Rgb = (0xCC, 0x79, 0xA7);
    pub const GREY: Rgb = (0x88, 0x88, 0x88);
    pub const DARK: Rgb = (0x22, 0x22, 0x22);
}

// Font sizes below are in SVG pixels; plotters gets them times FONT_SCALE.
const TITLE_PX: f64 = 14.0;
const LABEL_PX: f64 = 12.0;
const TICK_PX: f64 = 11.0;
const LEGEND_PX: f64 = 11.0;
/// Plotters' estimate of a character's width, as a fraction of the font size
/// in SVG pixels.
const CHAR_EM: f64 = 0.7 / FONT_SCALE;

/// How data values become plot coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mapping {
    Linear,
    Log10,
    /// log10 of positive values, zero at a fixed position left of them.
    NoiseLog {
        zero_at: f64,
    },
}

/// A resolved axis: mapping, range and ticks in plot coordinates.
#[derive(Debug, Clone)]
pub struct Axis {
    pub label: String,
    mapping: Mapping,
    lo: f64,
    hi: f64,
    ticks: Vec<(f64, String)>,
    minor: Vec<f64>,
    /// Draw values outside the range (and values <= 0 on a log axis) at the
    /// nearest edge instead of leaving them out.
    clamp: bool,
    /// Data values are multiplied by this before mapping (100 on noise axes:
    /// fractions shown in %).
    factor: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mapped {
    Value(f64),
    Clamped(f64),
    Skip,
}

impl Mapped {
    fn coord(self) -> Option<f64> {
        match self {
            Mapped::Value(u) | Mapped::Clamped(u) => Some(u),
            Mapped::Skip => None,
        }
    }
}

fn nice_step(span: f64, target: f64) -> f64 {
    let raw = (span / target).abs();
    if !raw.is_finite() || raw == 0.0 {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let r = raw / mag * (1.0 - 1e-9);
    let m = [1.0, 2.0, 2.5, 5.0]
        .into_iter()
        .find(|m| r <= *m)
        .unwrap_or(10.0);
    m * mag
}

/// Label of a linear tick at `v` on an axis with tick spacing `step`.
fn linear_tick_label(v: f64, step: f64, max_abs: f64) -> String {
    if v.abs() < step * 1e-6 {
        return "0".to_string();
    }
    if !(1e-3..1e5).contains(&max_abs) {
        let digits = (max_abs.log10().floor() - step.log10().floor()).clamp(0.0, 6.0) as usize;
        let s = format!("{:.*e}", digits, v);
        return s.replace("e0", "");
    }
    let exp = (step.log10() + 1e-9).floor();
    let mantissa = step / 10f64.powf(exp);
    let extra = if (mantissa - 2.5).abs() < 1e-6 {
        1.0
    } else {
        0.0
    };
    let decimals = (extra - exp).max(0.0) as usize;
    format!("{:.*}", decimals, v)
}

fn linear_ticks(lo: f64, hi: f64, target: f64) -> (f64, Vec<(f64, String)>) {
    let step = nice_step(hi - lo, target);
    let k0 = (lo / step - 1e-9).ceil() as i64;
    let k1 = (hi / step + 1e-9).floor() as i64;
    let max_abs = lo.abs().max(hi.abs());
    let ticks = (k0..=k1.min(k0.saturating_add(40)))
        .map(|k| {
            let v = k as f64 * step;
            (v, linear_tick_label(v, step, max_abs))
        })
        .collect();
    (step, ticks)
}

/// A finite, non-empty range around the finite values in `lo..hi`.
fn sane_range(lo: f64, hi: f64) -> (f64, f64) {
    match (lo.is_finite(), hi.is_finite()) {
        (true, true) if hi > lo => (lo, hi),
        (true, true) if lo == hi => {
            let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
            (lo - pad, hi + pad)
        }
        (true, false) => sane_range(lo, lo),
        (false, true) => sane_range(hi, hi),
        _ => (0.0, 1.0),
    }
}

/// Smallest and largest finite value.
pub fn finite_range<'a>(values: impl IntoIterator<Item = &'a f64>) -> (f64, f64) {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        })
}

impl Axis {
    /// Linear axis covering `lo..hi` (finite values), widened to whole ticks.
    pub fn linear(label: impl Into<String>, lo: f64, hi: f64) -> Axis {
        let (lo, hi) = sane_range(lo, hi);
        let step = nice_step(hi - lo, 7.0);
        let (lo, hi) = ((lo / step).floor() * step, (hi / step).ceil() * step);
        let (_, ticks) = linear_ticks(lo, hi, 7.0);
        Axis {
            label: label.into(),
            mapping: Mapping::Linear,
            lo,
            hi,
            ticks,
            minor: vec![],
            clamp: false,
            factor: 1.0,
        }
    }

    /// Linear axis over exactly `lo..hi`, ticks inside.
    pub fn linear_exact(label: impl Into<String>, lo: f64, hi: f64) -> Axis {
        let (lo, hi) = sane_range(lo, hi);
        let (_, ticks) = linear_ticks(lo, hi, 6.0);
        Axis {
            label: label.into(),
            mapping: Mapping::Linear,
            lo,
            hi,
            ticks,
            minor: vec![],
            clamp: false,
            factor: 1.0,
        }
    }

    /// Linear axis over `lo..hi` with ticks at the given values.
    pub fn fixed(label: impl Into<String>, lo: f64, hi: f64, ticks: &[f64]) -> Axis {
        let step = ticks
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(f64::INFINITY, f64::min);
        let step = if step.is_finite() && step > 0.0 {
            step
        } else {
            nice_step(hi - lo, 6.0)
        };
        let max_abs = lo.abs().max(hi.abs());
        Axis {
            label: label.into(),
            mapping: Mapping::Linear,
            lo,
            hi,
            ticks: ticks
                .iter()
                .map(|&v| (v, linear_tick_label(v, step, max_abs)))
                .collect(),
            minor: vec![],
            clamp: false,
            factor: 1.0,
        }
    }

    /// Integer axis (model orders, floors, indices) over `lo..hi`, padded by
    /// half a unit.
    pub fn integer(label: impl Into<String>, lo: f64, hi: f64) -> Axis {
        let (lo, hi) = if lo.is_finite() && hi.is_finite() && hi >= lo {
            (lo, hi)
        } else {
            (0.0, 1.0)
        };
        let step = nice_step(hi - lo, 8.0).max(1.0).round();
        let k0 = (lo / step).ceil() as i64;
        let k1 = (hi / step).floor() as i64;
        let ticks = (k0..=k1.min(k0.saturating_add(40)))
            .map(|k| {
                let v = k as f64 * step;
                (v, format!("{v:.0}"))
            })
            .collect();
        Axis {
            label: label.into(),
            mapping: Mapping::Linear,
            lo: lo - 0.5,
            hi: hi + 0.5,
            ticks,
            minor: vec![],
            clamp: false,
            factor: 1.0,
        }
    }

    /// Log axis covering the positive values `min_pos..max`, whole decades.
    /// Values <= 0 are drawn at the bottom (and counted in a note).
    pub fn log(label: impl Into<String>, min_pos: f64, max: f64) -> Axis {
        let (a, b) = if min_pos > 0.0 && min_pos.is_finite() && max.is_finite() && max >= min_pos {
            // Keep data at least 0.05 decade off the frame.
            (
                (min_pos.log10() - 0.05).floor(),
                (max.log10() + 0.05).ceil(),
            )
        } else {
            (0.0, 1.0)
        };
        let span = ((b - a).max(1.0)) as i64;
        // The smallest whole-decade step that needs at most 7 intervals.
        let step = (1..=span).find(|s| (span + s - 1) / s <= 7).unwrap_or(span);
        let n = (span + step - 1) / step;
        let (lo, hi) = (a, a + (n * step) as f64);
        let decades: Vec<i64> = (0..=n).map(|k| a as i64 + k * step).collect();
        let plain = decades.iter().all(|d| (-2..=3).contains(d));
        let label_of = |m: f64, d: i64| -> String {
            if plain {
                trim(m * 10f64.powi(d as i32), 3)
            } else if m == 1.0 {
                power_of_ten(d as i32)
            } else {
                format!("{}×{}", m, power_of_ten(d as i32))
            }
        };
        let mut ticks: Vec<(f64, String)> = decades
            .iter()
            .map(|&d| (d as f64, label_of(1.0, d)))
            .collect();
        let mut minor = vec![];
        if step == 1 && span <= 4 {
            for &d in &decades[..decades.len() - 1] {
                for m in 2..10 {
                    let u = d as f64 + (m as f64).log10();
                    if span <= 2 && (m == 2 || m == 5) {
                        ticks.push((u, label_of(m as f64, d)));
                    } else {
                        minor.push(u);
                    }
                }
            }
            ticks.sort_by(|x, y| x.0.total_cmp(&y.0));
        }
        Axis {
            label: label.into(),
            mapping: Mapping::Log10,
            lo,
            hi,
            ticks,
            minor,
            clamp: true,
            factor: 1.0,
        }
    }

    /// Noise-level axis in %, from levels given as fractions. Levels that
    /// span a decade or more get a log axis with 0 % drawn left of the
    /// smallest positive level; otherwise the axis is linear. Ticks sit at
    /// the levels themselves.
    pub fn noise(levels: &[f64]) -> Axis {
        let mut p: Vec<f64> = levels
            .iter()
            .filter(|v| v.is_finite() && **v >= 0.0)
            .map(|v| v * 100.0)
            .collect();
        p.sort_by(f64::total_cmp);
        p.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs().max(1e-300));
        let pos: Vec<f64> = p.iter().copied().filter(|v| *v > 0.0).collect();
        let thin = |ticks: Vec<(f64, String)>| -> Vec<(f64, String)> {
            let every = ticks.len().div_ceil(12).max(1);
            ticks.into_iter().step_by(every).collect()
        };
        if pos.len() >= 2 && pos[pos.len() - 1] / pos[0] >= 10.0 {
            let (a, b) = (pos[0].log10(), pos[pos.len() - 1].log10());
            let spacing = (b - a) / (pos.len() - 1) as f64;
            let zero_at = a - spacing.max(0.3);
            let has_zero = p[0] == 0.0;
            let pad = 0.35 * spacing.clamp(0.1, 1.0);
            let lo = if has_zero { zero_at } else { a } - pad;
            let ticks = p
                .iter()
                .map(|&v| {
                    let u = if v > 0.0 { v.log10() } else { zero_at };
                    (u, trim(v, 3))
                })
                .collect();
            return Axis {
                label: "Noise level [%] (log scale)".into(),
                mapping: Mapping::NoiseLog { zero_at },
                lo,
                hi: b + pad,
                ticks: thin(ticks),
                minor: vec![],
                clamp: false,
                factor: 100.0,
            };
        }
        let label = "Noise level [%]";
        let mut axis = match p.as_slice() {
            [] => Axis::linear_exact(label, 0.0, 1.0),
            [v] => {
                let pad = if *v > 0.0 { 0.5 * v } else { 1.0 };
                Axis::fixed(label, v - pad, v + pad, &[*v])
                    .with_tick_labels(vec![(*v, trim(*v, 3))])
            }
            _ => {
                let (a, b) = (p[0], p[p.len() - 1]);
                let pad = 0.06 * (b - a);
                let ticks = if p.len() <= 10 {
                    p.iter().map(|&v| (v, trim(v, 3))).collect()
                } else {
                    linear_ticks(a, b, 6.0).1
                };
                Axis::fixed(label, a - pad, b + pad, &[]).with_tick_labels(ticks)
            }
        };
        axis.factor = 100.0;
        axis
    }

    fn with_tick_labels(mut self, ticks: Vec<(f64, String)>) -> Axis {
        self.ticks = ticks;
        self
    }

    /// Draw values outside the range at the nearest edge.
    pub fn clamped(mut self) -> Axis {
        self.clamp = true;
        self
    }

    /// Whether `v` is drawn in the zero slot of a log noise axis, apart from
    /// the log-scaled positive values.
    fn in_zero_slot(&self, v: f64) -> bool {
        matches!(self.mapping, Mapping::NoiseLog { .. }) && v * self.factor == 0.0
    }

    /// Plot coordinate between the zero slot and the first positive tick of
    /// a log noise axis, where the axis is broken.
    fn break_at(&self) -> Option<f64> {
        let Mapping::NoiseLog { zero_at } = self.mapping else {
            return None;
        };
        let first = self
            .ticks
            .iter()
            .map(|t| t.0)
            .filter(|u| *u > zero_at + 1e-9)
            .fold(f64::INFINITY, f64::min);
        first.is_finite().then_some(0.5 * (zero_at + first))
    }

    /// Whether this is a log axis.
    pub fn is_log(&self) -> bool {
        self.mapping == Mapping::Log10
    }

    /// The bottom of the axis in data units (for notes).
    pub fn bottom_value(&self) -> f64 {
        match self.mapping {
            Mapping::Log10 => 10f64.powf(self.lo),
            _ => self.lo,
        }
    }

    fn map(&self, v: f64) -> Mapped {
        let v = v * self.factor;
        if !v.is_finite() {
            return Mapped::Skip;
        }
        let u = match self.mapping {
            Mapping::Linear => v,
            Mapping::Log10 => {
                if v > 0.0 {
                    v.log10()
                } else if self.clamp {
                    return Mapped::Clamped(self.lo);
                } else {
                    return Mapped::Skip;
                }
            }
            Mapping::NoiseLog { zero_at } => {
                if v > 0.0 {
                    v.log10()
                } else if v == 0.0 {
                    zero_at
                } else {
                    return Mapped::Skip;
                }
            }
        };
        let tol = 1e-9 * (self.hi - self.lo);
        if u < self.lo - tol || u > self.hi + tol {
            if self.clamp {
                Mapped::Clamped(u.clamp(self.lo, self.hi))
            } else {
                Mapped::Skip
            }
        } else {
            Mapped::Value(u.clamp(self.lo, self.hi))
        }
    }

    fn label_at(&self, u: f64) -> String {
        let tol = 1e-6 * (self.hi - self.lo).abs().max(1e-300);
        self.ticks
            .iter()
            .find(|(t, _)| (t - u).abs() <= tol)
            .map(|(_, l)| l.clone())
            .unwrap_or_default()
    }
}

/// Marker shapes; each marker is exactly one SVG element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    Circle,
    Square,
    Triangle,
}

/// What a layer draws.
#[derive(Debug, Clone)]
pub enum LayerKind {
    /// A polyline; non-finite points break it. `envelope` reduces records
    /// longer than twice the plot width to a min/max envelope per pixel
    /// column. `max_jump` breaks the line where y jumps by more than this
    /// (in y data units; phase wrapping).
    Line {
        points: Vec<(f64, f64)>,
        width: u32,
        dashed: bool,
        envelope: bool,
        max_jump: Option<f64>,
    },
    Markers {
        points: Vec<(f64, f64)>,
        shape: Shape,
        filled: bool,
        size: u32,
    },
    /// A filled band between `lo` and `hi`.
    Band {
        x: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
    },
    /// A vertical rule at x with an optional label.
    VRule { x: f64, label: Option<String> },
    /// A horizontal rule at y with an optional label.
    HRule { y: f64, label: Option<String> },
}

/// One data layer; layers with the same key share one legend entry.
#[derive(Debug, Clone)]
pub struct Layer {
    pub key: String,
    pub legend: Option<String>,
    pub color: Rgb,
    pub kind: LayerKind,
}

impl Layer {
    pub fn line(key: &str, legend: Option<&str>, color: Rgb, points: Vec<(f64, f64)>) -> Layer {
        Layer {
            key: key.into(),
            legend: legend.map(Into::into),
            color,
            kind: LayerKind::Line {
                points,
                width: 1,
                dashed: false,
                envelope: true,
                max_jump: None,
            },
        }
    }

    pub fn markers(
        key: &str,
        legend: Option<&str>,
        color: Rgb,
        points: Vec<(f64, f64)>,
        shape: Shape,
        filled: bool,
    ) -> Layer {
        Layer {
            key: key.into(),
            legend: legend.map(Into::into),
            color,
            kind: LayerKind::Markers {
                points,
                shape,
                filled,
                size: 3,
            },
        }
    }

    pub fn band(
        key: &str,
        legend: Option<&str>,
        color: Rgb,
        x: &[f64],
        lo: &[f64],
        hi: &[f64],
    ) -> Layer {
        Layer {
            key: key.into(),
            legend: legend.map(Into::into),
            color,
            kind: LayerKind::Band {
                x: x.to_vec(),
                lo: lo.to_vec(),
                hi: hi.to_vec(),
            },
        }
    }

    pub fn vrule(key: &str, color: Rgb, x: f64, label: Option<String>) -> Layer {
        Layer {
            key: key.into(),
            legend: None,
            color,
            kind: LayerKind::VRule { x, label },
        }
    }

    pub fn hrule(key: &str, color: Rgb, y: f64, label: Option<String>) -> Layer {
        Layer {
            key: key.into(),
            legend: None,
            color,
            kind: LayerKind::HRule { y, label },
        }
    }

    /// Sets the line width (lines only).
    pub fn width(mut self, w: u32) -> Layer {
        if let LayerKind::Line { width, .. } = &mut self.kind {
            *width = w;
        }
        self
    }

    /// Dashed line.
    pub fn dashed(mut self) -> Layer {
        if let LayerKind::Line { dashed, .. } = &mut self.kind {
            *dashed = true;
        }
        self
    }

    /// Breaks the line where y jumps by more than `jump`.
    pub fn break_on_jump(mut self, jump: f64) -> Layer {
        if let LayerKind::Line { max_jump, .. } = &mut self.kind {
            *max_jump = Some(jump);
        }
        self
    }

    fn role(&self) -> &'static str {
        match self.kind {
            LayerKind::Line { .. } => "line",
            LayerKind::Markers { .. } => "markers",
            LayerKind::Band { .. } => "band",
            LayerKind::VRule { .. } | LayerKind::HRule { .. } => "rule",
        }
    }
}

/// A chart to draw.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Unique in the document.
    pub id: String,
    /// What the chart shows (`data-chart`), e.g. "force", "hankel".
    pub kind: String,
    pub title: String,
    pub size: (u32, u32),
    pub x: Axis,
    pub y: Axis,
    pub layers: Vec<Layer>,
}

/// A drawn chart: inline SVG and notes for its caption.
#[derive(Debug, Clone)]
pub struct Drawn {
    pub svg: String,
    pub notes: Vec<String>,
}

/// A plot coordinate range with the axis' own ticks (bold mesh lines and
/// labels) and minor ticks (light mesh lines).
#[derive(Clone)]
struct PlotRange {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl PlotRange {
    fn of(axis: &Axis) -> PlotRange {
        PlotRange {
            lo: axis.lo,
            hi: axis.hi,
            ticks: axis.ticks.iter().map(|t| t.0).collect(),
            minor: axis.minor.clone(),
        }
    }
}

impl Ranged for PlotRange {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let span = self.hi - self.lo;
        if span == 0.0 || !v.is_finite() {
            return (limit.0 + limit.1) / 2;
        }
        let t = ((v - self.lo) / span).clamp(-1.0, 2.0);
        limit.0 + ((limit.1 - limit.0) as f64 * t).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

type Root<'a> = DrawingArea<SvgCanvas<'a>, Shift>;

/// Opens a group: what is drawn until the matching [`close`] goes into it.
fn open(root: &Root<'_>, group: Group) -> Result<(), String> {
    root.draw(&GroupMark::Open(group))
        .map_err(|e| e.to_string())
}

/// Closes the innermost open group.
fn close(root: &Root<'_>) -> Result<(), String> {
    root.draw(&GroupMark::Close).map_err(|e| e.to_string())
}

/// The group of one data layer.
fn series(key: &str, role: &str, points: usize, dashed: bool) -> Group {
    let group = Group::class("series")
        .attr("data-series", key)
        .attr("data-role", role)
        .attr("data-points", points);
    dash(group, dashed)
}

/// Dashes the lines of a group (its elements inherit the attribute).
fn dash(group: Group, dashed: bool) -> Group {
    if dashed {
        group.attr("stroke-dasharray", "6 4")
    } else {
        group
    }
}

/// Data values that could not be drawn as they are, each counted once even
/// when a line and markers show the same series: (series, index, part).
#[derive(Default)]
struct Tally {
    keys: Vec<String>,
    skipped: BTreeSet<(usize, usize, u8)>,
    clamped: BTreeSet<(usize, usize, u8)>,
}

impl Tally {
    fn series(&mut self, key: &str) -> usize {
        match self.keys.iter().position(|k| k == key) {
            Some(i) => i,
            None => {
                self.keys.push(key.to_string());
                self.keys.len() - 1
            }
        }
    }

    /// Records how the coordinates of value `i` (part `part`) were mapped.
    fn record(&mut self, series: usize, i: usize, part: u8, mapped: &[Mapped]) {
        if mapped.contains(&Mapped::Skip) {
            self.skipped.insert((series, i, part));
        } else if mapped.iter().any(|m| matches!(m, Mapped::Clamped(_))) {
            self.clamped.insert((series, i, part));
        }
    }
}

fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

fn font(px: f64) -> FontDesc<'static> {
    ("sans-serif", px * FONT_SCALE).into_font()
}

/// Text for plotters, which escapes markup but passes control characters
/// through; they are not allowed in HTML.
fn clean(s: &str) -> String {
    s.chars().filter(|c| !c.is_control()).collect()
}

fn text_width(text: &str, px: f64) -> f64 {
    text.chars().count() as f64 * px * CHAR_EM
}

/// A legend entry: what the layers with one key look like.
struct Entry {
    key: String,
    label: String,
    color: Rgb,
    line: Option<bool>,
    marker: Option<(Shape, bool, Rgb)>,
    band: bool,
}

fn legend_entries(layers: &[Layer]) -> Vec<Entry> {
    let mut entries: Vec<Entry> = vec![];
    for layer in layers {
        let Some(label) = &layer.legend else { continue };
        let i = match entries.iter().position(|e| e.key == layer.key) {
            Some(i) => i,
            None => {
                entries.push(Entry {
                    key: layer.key.clone(),
                    label: label.clone(),
                    color: layer.color,
                    line: None,
                    marker: None,
                    band: false,
                });
                entries.len() - 1
            }
        };
        let e = &mut entries[i];
        match &layer.kind {
            LayerKind::Line { dashed, .. } => {
                e.line = Some(*dashed);
                e.color = layer.color;
            }
            LayerKind::Markers { shape, filled, .. } => {
                e.marker = Some((*shape, *filled, layer.color));
            }
            LayerKind::Band { .. } => e.band = true,
            _ => {}
        }
    }
    entries
}

const LEGEND_ROW: i32 = 18;
const LEGEND_SAMPLE: i32 = 26;

fn entry_width(e: &Entry) -> i32 {
    LEGEND_SAMPLE + 6 + text_width(&e.label, LEGEND_PX).ceil() as i32 + 18
}

/// Rows of entry indices that fit in `width`.
fn legend_rows(entries: &[Entry], width: i32) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = vec![];
    let mut used = 0;
    for (i, e) in entries.iter().enumerate() {
        let w = entry_width(e);
        match rows.last_mut() {
            Some(row) if used + w <= width => {
                row.push(i);
                used += w;
            }
            _ => {
                rows.push(vec![i]);
                used = w;
            }
        }
    }
    rows
}

fn marker_element(
    root: &Root<'_>,
    (x, y): (i32, i32),
    shape: Shape,
    filled: bool,
    size: u32,
    color: Rgb,
) -> Result<(), String> {
    let c = rgb(color);
    let style = if filled {
        c.filled()
    } else {
        c.stroke_width(1)
    };
    let s = size as i32;
    let r = match shape {
        Shape::Circle => root.draw(&Circle::new((x, y), size, style)),
        Shape::Square => root.draw(&Rectangle::new([(x - s, y - s), (x + s, y + s)], style)),
        Shape::Triangle => {
            let h = s + 1;
            let pts = vec![(x, y - h), (x + h, y + s), (x - h, y + s)];
            if filled {
                root.draw(&Polygon::new(pts, style))
            } else {
                let mut closed = pts.clone();
                closed.push(pts[0]);
                root.draw(&PathElement::new(closed, style))
            }
        }
    };
    r.map_err(|e| e.to_string())
}

/// Reduces a run of pixel points (x ascending) to its min/max envelope per
/// pixel column when it is longer than twice the number of columns; drops
/// consecutive duplicates.
pub(crate) fn envelope(points: &[(i32, i32)], columns: i32) -> Vec<(i32, i32)> {
    if points.len() as i64 <= 2 * columns.max(1) as i64 {
        return points.to_vec();
    }
    let mut out: Vec<(i32, i32)> = Vec::with_capacity(2 * columns as usize + 2);
    let push = |p: (i32, i32), out: &mut Vec<(i32, i32)>| {
        if out.last() != Some(&p) {
            out.push(p);
        }
    };
    let mut i = 0;
    while i < points.len() {
        let col = points[i].0;
        let (mut lo, mut hi) = (i, i);
        let mut j = i;
        while j < points.len() && points[j].0 == col {
            if points[j].1 < points[lo].1 {
                lo = j;
            }
            if points[j].1 > points[hi].1 {
                hi = j;
            }
            j += 1;
        }
        let (first, second) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        push(points[i], &mut out);
        push(points[first], &mut out);
        push(points[second], &mut out);
        push(points[j - 1], &mut out);
        i = j;
    }
    out
}

/// Draws a chart.
pub fn draw(chart: &Chart) -> Result<Drawn, ReportError> {
    let fail = |detail: String| ReportError::Chart {
        chart: chart.id.clone(),
        detail,
    };
    let mut svg = String::new();
    let mut tally = Tally::default();
    draw_into(chart, &mut svg, &mut tally).map_err(fail)?;

    let mut notes = vec![];
    let (skipped, clamped) = (tally.skipped.len(), tally.clamped.len());
    if skipped > 0 {
        notes.push(format!(
            "{skipped} non-finite or out-of-range value(s) not drawn."
        ));
    }
    if clamped > 0 {
        if chart.y.is_log() {
            notes.push(format!(
                "{clamped} value(s) ≤ 0 or below the axis drawn at its bottom ({}).",
                crate::format::sig(chart.y.bottom_value(), 2)
            ));
        } else {
            notes.push(format!(
                "{clamped} value(s) outside the axis range drawn at its edge."
            ));
        }
    }
    Ok(Drawn { svg, notes })
}

/// Draws the chart as an `svg.chart` element into `buf`.
fn draw_into(chart: &Chart, buf: &mut String, tally: &mut Tally) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<SvgError>| e.to_string();
    let (w, h) = chart.size;
    let root_attrs = Group::class("chart")
        .attr("id", format_args!("{}-svg", chart.id))
        .attr("data-chart", &chart.kind)
        .attr("role", "img")
        .attr("aria-labelledby", format_args!("{}-title", chart.id));
    let title_id = format!("{}-title", chart.id);
    let root =
        SvgCanvas::new(buf, (w, h), &root_attrs, &title_id, &chart.title).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;

    // Title, shrunk to fit.
    let avail = w as f64 - 16.0;
    let px = (avail / (text_width(&chart.title, 1.0) * 1.06).max(1e-9)).clamp(8.0, TITLE_PX);
    open(&root, Group::class("chart-title"))?;
    let body = root
        .titled(
            &clean(&chart.title),
            font(px).style(FontStyle::Bold).color(&rgb(palette::DARK)),
        )
        .map_err(e)?;
    close(&root)?;

    // Legend below the plot when there is more than one entry.
    let entries = legend_entries(&chart.layers);
    let show_legend = entries.len() >= 2;
    let rows = if show_legend {
        legend_rows(&entries, w as i32 - 24)
    } else {
        vec![]
    };
    let legend_h = if rows.is_empty() {
        0
    } else {
        rows.len() as i32 * LEGEND_ROW + 6
    };
    let body_h = body.dim_in_pixel().1 as i32;
    let (upper, _) = body.split_vertically((body_h - legend_h).max(body_h / 2));

    let y_tick_chars = chart
        .y
        .ticks
        .iter()
        .map(|(_, l)| l.chars().count())
        .max()
        .unwrap_or(1);
    let y_area = (22.0 + 10.0 + y_tick_chars as f64 * TICK_PX * CHAR_EM).clamp(44.0, 120.0) as u32;
    let x_range = PlotRange::of(&chart.x);
    let y_range = PlotRange::of(&chart.y);
    let mut cc = ChartBuilder::on(&upper)
        .margin_top(6)
        .margin_right(18)
        .margin_left(4)
        .x_label_area_size(42)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x_range, y_range)
        .map_err(e)?;

    open(&root, Group::class("axes"))?;
    let xf = |v: &f64| clean(&chart.x.label_at(*v));
    let yf = |v: &f64| clean(&chart.y.label_at(*v));
    cc.configure_mesh()
        .bold_line_style(RGBColor(0xD9, 0xD9, 0xD9))
        .light_line_style(RGBColor(0xF0, 0xF0, 0xF0))
        .axis_style(RGBColor(0x55, 0x55, 0x55))
        .label_style(font(TICK_PX).color(&RGBColor(0x33, 0x33, 0x33)))
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .draw()
        .map_err(e)?;
    close(&root)?;

    let plot = cc.plotting_area().clone();
    let (px_range, py_range) = plot.get_pixel_range();
    let columns = px_range.end - px_range.start;

    // Axis labels.
    let label_style = font(LABEL_PX).color(&RGBColor(0x22, 0x22, 0x22));
    open(&root, Group::class("axis-label").attr("data-axis", "x"))?;
    root.draw(&Text::new(
        clean(&chart.x.label),
        ((px_range.start + px_range.end) / 2, py_range.end + 22),
        label_style.clone().pos(Pos::new(HPos::Center, VPos::Top)),
    ))
    .map_err(e)?;
    close(&root)?;
    open(&root, Group::class("axis-label").attr("data-axis", "y"))?;
    root.draw(&Text::new(
        clean(&chart.y.label),
        (4, (py_range.start + py_range.end) / 2),
        label_style
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Top)),
    ))
    .map_err(e)?;
    close(&root)?;

    let to_px = |u: (f64, f64)| plot.map_coordinate(&u);

    // Axis break between 0 % and the log-scaled noise levels.
    if let Some(u) = chart.x.break_at() {
        let (bx, by) = to_px((u, chart.y.lo));
        open(&root, Group::class("axis-break"))?;
        let axis = RGBColor(0x55, 0x55, 0x55).stroke_width(1);
        root.draw(&Rectangle::new(
            [(bx - 4, by - 6), (bx + 4, by + 6)],
            WHITE.filled(),
        ))
        .map_err(e)?;
        for dx in [-4, 1] {
            root.draw(&PathElement::new(
                vec![(bx + dx - 2, by + 5), (bx + dx + 2, by - 5)],
                axis,
            ))
            .map_err(e)?;
        }
        close(&root)?;
    }

    for layer in &chart.layers {
        let sid = tally.series(&layer.key);
        let color = rgb(layer.color);
        let role = layer.role();
        match &layer.kind {
            LayerKind::Line {
                points,
                width,
                dashed,
                envelope: env,
                max_jump,
            } => {
                let mut runs: Vec<Vec<(i32, i32)>> = vec![];
                let mut current: Vec<(i32, i32)> = vec![];
                let mut prev_y: Option<f64> = None;
                let mut prev_zero: Option<bool> = None;
                let mut n = 0;
                for (i, &(x, y)) in points.iter().enumerate() {
                    let (mx, my) = (chart.x.map(x), chart.y.map(y));
                    tally.record(sid, i, 0, &[mx, my]);
                    match (mx.coord(), my.coord()) {
                        (Some(u), Some(v)) => {
                            n += 1;
                            let zero = chart.x.in_zero_slot(x);
                            let jump = match (max_jump, prev_y) {
                                (Some(j), Some(p)) => (y - p).abs() > *j,
                                _ => false,
                            } || prev_zero.is_some_and(|z| z != zero);
                            prev_zero = Some(zero);
                            if jump && !current.is_empty() {
                                runs.push(std::mem::take(&mut current));
                            }
                            current.push(to_px((u, v)));
                            prev_y = Some(y);
                        }
                        _ => {
                            prev_y = None;
                            prev_zero = None;
                            if !current.is_empty() {
                                runs.push(std::mem::take(&mut current));
                            }
                        }
                    }
                }
                if !current.is_empty() {
                    runs.push(current);
                }
                open(&root, series(&layer.key, role, n, *dashed))?;
                let style = color.stroke_width(*width);
                for run in runs {
                    let run = if *env { envelope(&run, columns) } else { run };
                    if run.len() >= 2 {
                        root.draw(&PathElement::new(run, style)).map_err(e)?;
                    }
                }
                close(&root)?;
            }
            LayerKind::Markers {
                points,
                shape,
                filled,
                size,
            } => {
                let mut pixels = vec![];
                for (i, &(x, y)) in points.iter().enumerate() {
                    let (mx, my) = (chart.x.map(x), chart.y.map(y));
                    tally.record(sid, i, 0, &[mx, my]);
                    if let (Some(u), Some(v)) = (mx.coord(), my.coord()) {
                        pixels.push(to_px((u, v)));
                    }
                }
                open(&root, series(&layer.key, role, pixels.len(), false))?;
                for p in pixels {
                    marker_element(&root, p, *shape, *filled, *size, layer.color)?;
                }
                close(&root)?;
            }
            LayerKind::Band { x, lo, hi } => {
                let mut runs: Vec<Vec<(i32, i32, i32)>> = vec![];
                let mut current = vec![];
                let mut n = 0;
                let mut prev_zero: Option<bool> = None;
                for i in 0..x.len().min(lo.len()).min(hi.len()) {
                    let (mx, ml, mh) = (chart.x.map(x[i]), chart.y.map(lo[i]), chart.y.map(hi[i]));
                    tally.record(sid, i, 1, &[mx, ml]);
                    tally.record(sid, i, 2, &[mx, mh]);
                    match (mx.coord(), ml.coord(), mh.coord()) {
                        (Some(u), Some(a), Some(b)) => {
                            n += 1;
                            let zero = chart.x.in_zero_slot(x[i]);
                            if prev_zero.is_some_and(|z| z != zero) && !current.is_empty() {
                                runs.push(std::mem::take(&mut current));
                            }
                            prev_zero = Some(zero);
                            let (px, pa) = to_px((u, a));
                            let (_, pb) = to_px((u, b));
                            current.push((px, pa, pb));
                        }
                        _ => {
                            prev_zero = None;
                            if !current.is_empty() {
                                runs.push(std::mem::take(&mut current));
                            }
                        }
                    }
                }
                if !current.is_empty() {
                    runs.push(current);
                }
                open(&root, series(&layer.key, role, n, false))?;
                for run in runs {
                    if run.len() == 1 {
                        let (px, pa, pb) = run[0];
                        root.draw(&PathElement::new(
                            vec![(px, pa), (px, pb)],
                            color.mix(0.45).stroke_width(4),
                        ))
                        .map_err(e)?;
                    } else {
                        let mut poly: Vec<(i32, i32)> =
                            run.iter().map(|&(x, _, b)| (x, b)).collect();
                        poly.extend(run.iter().rev().map(|&(x, a, _)| (x, a)));
                        root.draw(&Polygon::new(poly, color.mix(0.2).filled()))
                            .map_err(e)?;
                    }
                }
                close(&root)?;
            }
            LayerKind::VRule { x, label } => {
                let Some(u) = chart.x.map(*x).coord() else {
                    continue;
                };
                let (px, _) = to_px((u, chart.y.lo));
                open(&root, series(&layer.key, role, 1, true))?;
                root.draw(&PathElement::new(
                    vec![(px, py_range.start), (px, py_range.end)],
                    color.stroke_width(1),
                ))
                .map_err(e)?;
                if let Some(l) = label {
                    root.draw(&Text::new(
                        clean(l),
                        (px + 3, py_range.start + 2),
                        font(TICK_PX)
                            .color(&color)
                            .pos(Pos::new(HPos::Left, VPos::Top)),
                    ))
                    .map_err(e)?;
                }
                close(&root)?;
            }
            LayerKind::HRule { y, label } => {
                let Some(v) = chart.y.map(*y).coord() else {
                    continue;
                };
                let (_, py) = to_px((chart.x.lo, v));
                open(&root, series(&layer.key, role, 1, true))?;
                root.draw(&PathElement::new(
                    vec![(px_range.start, py), (px_range.end, py)],
                    color.stroke_width(1),
                ))
                .map_err(e)?;
                if let Some(l) = label {
                    root.draw(&Text::new(
                        clean(l),
                        (px_range.end - 4, py - 3),
                        font(TICK_PX)
                            .color(&color)
                            .pos(Pos::new(HPos::Right, VPos::Bottom)),
                    ))
                    .map_err(e)?;
                }
                close(&root)?;
            }
        }
    }

    if show_legend {
        open(&root, Group::class("legend"))?;
        let top = body.get_pixel_range().1.end - legend_h + 2;
        for (r, row) in rows.iter().enumerate() {
            let total: i32 = row.iter().map(|&i| entry_width(&entries[i])).sum();
            let mut x = ((w as i32 - total) / 2).max(8);
            let y = top + r as i32 * LEGEND_ROW + LEGEND_ROW / 2;
            for &i in row {
                let entry = &entries[i];
                let c = rgb(entry.color);
                open(
                    &root,
                    Group::class("legend-entry").attr("data-series", &entry.key),
                )?;
                if entry.band {
                    root.draw(&Rectangle::new(
                        [(x, y - 5), (x + LEGEND_SAMPLE, y + 5)],
                        c.mix(0.2).filled(),
                    ))
                    .map_err(e)?;
                }
                if let Some(dashed) = entry.line {
                    open(&root, dash(Group::class("legend-line"), dashed))?;
                    root.draw(&PathElement::new(
                        vec![(x, y), (x + LEGEND_SAMPLE, y)],
                        c.stroke_width(2),
                    ))
                    .map_err(e)?;
                    close(&root)?;
                }
                if let Some((shape, filled, mc)) = entry.marker {
                    marker_element(&root, (x + LEGEND_SAMPLE / 2, y), shape, filled, 3, mc)?;
                }
                root.draw(&Text::new(
                    clean(&entry.label),
                    (x + LEGEND_SAMPLE + 6, y),
                    font(LEGEND_PX)
                        .color(&RGBColor(0x22, 0x22, 0x22))
                        .pos(Pos::new(HPos::Left, VPos::Center)),
                ))
                .map_err(e)?;
                close(&root)?;
                x += entry_width(entry);
            }
        }
        close(&root)?;
    }
    root.present().map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(10.0, 5.0), 2.0);
        assert_eq!(nice_step(1.0, 4.0), 0.25 * 1.0);
        assert_eq!(nice_step(0.7, 6.0), 0.2);
        assert!((nice_step(3e-5, 6.0) - 5e-6).abs() < 1e-18);
    }

    #[test]
    fn tick_labels() {
        let (_, t) = linear_ticks(-1.0, 1.0, 4.0);
        let labels: Vec<_> = t.iter().map(|t| t.1.as_str()).collect();
        assert_eq!(labels, ["-1.0", "-0.5", "0", "0.5", "1.0"]);
        let (_, t) = linear_ticks(0.0, 30.0, 6.0);
        let labels: Vec<_> = t.iter().map(|t| t.1.as_str()).collect();
        assert_eq!(labels, ["0", "5", "10", "15", "20", "25", "30"]);
    }

    #[test]
    fn log_axis_clamps_non_positive_values() {
        let a = Axis::log("e", 3e-12, 0.2);
        assert_eq!((a.lo, a.hi), (-12.0, 0.0));
        assert_eq!(a.map(0.0), Mapped::Clamped(-12.0));
        assert_eq!(a.map(-1.0), Mapped::Clamped(-12.0));
        assert_eq!(a.map(f64::NAN), Mapped::Skip);
        assert_eq!(a.map(1e-3), Mapped::Value(-3.0));
    }

    #[test]
    fn noise_axis_puts_zero_left_of_a_log_axis() {
        let a = Axis::noise(&[0.0, 0.001, 0.01, 0.03, 0.1]);
        let Mapping::NoiseLog { zero_at } = a.mapping else {
            panic!("expected a log noise axis");
        };
        assert!(zero_at < -1.0);
        assert_eq!(a.map(0.0), Mapped::Value(zero_at));
        assert_eq!(a.ticks.len(), 5);
        assert_eq!(a.ticks[1].1, "0.1");
        let lin = Axis::noise(&[0.01, 0.02, 0.05]);
        assert_eq!(lin.mapping, Mapping::Linear);
        assert_eq!(lin.map(0.02), Mapped::Value(2.0));
        let single = Axis::noise(&[0.0]);
        assert_eq!(single.map(0.0), Mapped::Value(0.0));
        let empty = Axis::noise(&[]);
        assert!(empty.hi > empty.lo);
    }

    #[test]
    fn envelope_keeps_peaks_and_order() {
        let pts: Vec<(i32, i32)> = (0..1000)
            .map(|i| (i / 10, if i == 537 { -50 } else { i % 7 }))
            .collect();
        let env = envelope(&pts, 100);
        assert!(env.len() <= 4 * 100);
        assert!(env.contains(&(53, -50)));
        assert!(env.windows(2).all(|w| w[0].0 <= w[1].0));
        // Short runs are untouched.
        let short: Vec<(i32, i32)> = (0..50).map(|i| (i, i)).collect();
        assert_eq!(envelope(&short, 100), short);
    }
}
