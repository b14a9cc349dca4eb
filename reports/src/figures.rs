//! The charts of a study, built from the model.

use crate::chart::palette::{BLUE, DARK, GREEN, GREY, ORANGE, PURPLE, VERMILLION};
use crate::chart::{Axis, Chart, Layer, Shape, finite_range};
use crate::format::{escape, noise_percent, sig, trim};
use crate::model::{
    Frf, ModeShape, Panel, Quantity, Representative, Scale, Stability, StabilizationPoint,
};

/// A chart with its caption (HTML) and extra attributes for its `<figure>`.
pub struct Fig {
    pub chart: Chart,
    pub caption: String,
    pub attrs: String,
}

impl Fig {
    fn new(chart: Chart, caption: String) -> Fig {
        Fig {
            chart,
            caption,
            attrs: String::new(),
        }
    }
}

/// Sizes in SVG pixels; the page scales them to its width.
const WIDE: (u32, u32) = (760, 250);
const MEDIUM: (u32, u32) = (600, 360);
const HALF: (u32, u32) = (440, 300);

fn magnitude(c: [f64; 2]) -> f64 {
    c[0].hypot(c[1])
}

fn phase_deg(c: [f64; 2]) -> f64 {
    if c[0].is_finite() && c[1].is_finite() {
        c[1].atan2(c[0]).to_degrees()
    } else {
        f64::NAN
    }
}

/// Phase in [-90, 270) degrees: in-phase (0) and anti-phase (180)
/// components of nearly real mode shapes stay apart from the wrap.
fn mode_phase_deg(c: [f64; 2]) -> f64 {
    let p = phase_deg(c);
    if p < -90.0 { p + 360.0 } else { p }
}

fn db(c: [f64; 2]) -> f64 {
    20.0 * magnitude(c).log10()
}

/// Modal assurance criterion of two complex shapes over their common DOFs.
pub fn mac(a: &[[f64; 2]], b: &[[f64; 2]]) -> Option<f64> {
    let n = a.len().min(b.len());
    if n == 0 {
        return None;
    }
    let (mut re, mut im, mut na, mut nb) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let ([ar, ai], [br, bi]) = (a[i], b[i]);
        // conj(a) * b
        re += ar * br + ai * bi;
        im += ar * bi - ai * br;
        na += ar * ar + ai * ai;
        nb += br * br + bi * bi;
    }
    let m = (re * re + im * im) / (na * nb);
    m.is_finite().then_some(m)
}

/// Time axis of a record of `n` samples; falls back to sample numbers when
/// the sampling interval is unusable.
fn time_axis(n: usize, dt: f64) -> (Axis, f64, Option<String>) {
    let last = n.saturating_sub(1).max(1) as f64;
    if dt.is_finite() && dt > 0.0 {
        (Axis::linear_exact("Time [s]", 0.0, last * dt), dt, None)
    } else {
        (
            Axis::linear_exact("Sample", 0.0, last),
            1.0,
            Some(
                "The sampling interval is not a positive number; samples are numbered instead."
                    .into(),
            ),
        )
    }
}

fn record_points(values: &[f64], dt: f64) -> Vec<(f64, f64)> {
    values
        .iter()
        .enumerate()
        .map(|(i, &v)| (i as f64 * dt, v))
        .collect()
}

/// The hammer force of hit 1 (the paper's Fig. 2).
pub fn force(prefix: &str, rep: &Representative) -> Fig {
    let n = rep.force.len();
    let (x, dt, note) = time_axis(n, rep.dt_s);
    let (lo, hi) = finite_range(&rep.force);
    let chart = Chart {
        id: format!("{prefix}-force"),
        kind: "force".into(),
        title: format!("Hammer force, hit 1, floor {}", rep.hit_floor),
        size: WIDE,
        x,
        y: Axis::linear("Force [N]", lo, hi),
        layers: vec![Layer::line(
            "force",
            Some("force"),
            DARK,
            record_points(&rep.force, dt),
        )],
    };
    let mut caption = format!(
        "Force of the first hit, {n} samples (cf. the paper's Fig. 2). Long records are drawn as a min/max envelope per pixel column, so peaks are kept."
    );
    if let Some(note) = note {
        caption.push(' ');
        caption.push_str(&note);
    }
    Fig::new(chart, caption)
}

/// Accelerations of hit 1, one chart per floor on a common scale (the
/// paper's Fig. 3).
pub fn accelerations(prefix: &str, rep: &Representative) -> Vec<Fig> {
    let (lo, hi) = finite_range(rep.accelerations.iter().flatten());
    rep.accelerations
        .iter()
        .enumerate()
        .map(|(j, rec)| {
            let (x, dt, note) = time_axis(rec.len(), rep.dt_s);
            let chart = Chart {
                id: format!("{prefix}-acceleration-{}", j + 1),
                kind: "acceleration".into(),
                title: format!("Acceleration, floor {}, hit 1", j + 1),
                size: WIDE,
                x,
                y: Axis::linear("Acceleration [m/s²]", lo, hi),
                layers: vec![Layer::line(
                    "acceleration",
                    Some("acceleration"),
                    BLUE,
                    record_points(rec, dt),
                )],
            };
            let mut caption = format!(
                "Floor {} response to the first hit, {} samples (cf. the paper's Fig. 3); all floors share one scale.",
                j + 1,
                rec.len()
            );
            if let Some(note) = note {
                caption.push(' ');
                caption.push_str(&note);
            }
            let mut fig = Fig::new(chart, caption);
            fig.attrs = format!(" data-floor=\"{}\"", j + 1);
            fig
        })
        .collect()
}

/// Hankel singular values on a log scale, the chosen order marked (the
/// paper's Fig. 4).
pub fn hankel(prefix: &str, rep: &Representative) -> Fig {
    let sv = &rep.hankel_singular_values;
    let (min_pos, max) = finite_range(sv.iter().filter(|v| **v > 0.0));
    let y = Axis::log("Singular value", min_pos, max);
    let x = Axis::integer("Index", 1.0, sv.len().max(1) as f64);
    let order = rep.order;
    let pts = |range: std::ops::Range<usize>| -> Vec<(f64, f64)> {
        range.map(|i| ((i + 1) as f64, sv[i])).collect()
    };
    let kept = order.min(sv.len());
    let mut layers = vec![
        Layer::markers(
            "retained",
            Some(&format!("retained (n = {order})")),
            BLUE,
            pts(0..kept),
            Shape::Circle,
            true,
        ),
        Layer::markers(
            "discarded",
            Some("discarded"),
            GREY,
            pts(kept..sv.len()),
            Shape::Circle,
            false,
        ),
    ];
    let mut caption = format!(
        "{} singular values of the Hankel matrix (cf. the paper's Fig. 4); the first {order} are kept as the state dimension.",
        sv.len()
    );
    if order > 0 && order < sv.len() {
        layers.push(Layer::vrule(
            "order",
            VERMILLION,
            order as f64 + 0.5,
            Some(format!("n = {order}")),
        ));
        let gap = sv[order - 1] / sv[order];
        if gap.is_finite() && gap > 0.0 {
            caption.push_str(&format!(
                " The gap at the chosen order is a factor {}.",
                sig(gap, 3)
            ));
        }
    } else if order > sv.len() {
        caption.push_str(" The chosen order exceeds the number of singular values given.");
    }
    Fig::new(
        Chart {
            id: format!("{prefix}-hankel"),
            kind: "hankel".into(),
            title: format!("Hankel matrix singular values, order n = {order}"),
            size: MEDIUM,
            x,
            y,
            layers,
        },
        caption,
    )
}

/// How a stability status is drawn.
struct StatusStyle {
    status: Stability,
    key: &'static str,
    legend: &'static str,
    color: (u8, u8, u8),
    shape: Shape,
    filled: bool,
}

const STATUS_STYLE: [StatusStyle; 4] = [
    StatusStyle {
        status: Stability::New,
        key: "new",
        legend: "new pole",
        color: GREY,
        shape: Shape::Circle,
        filled: false,
    },
    StatusStyle {
        status: Stability::Frequency,
        key: "frequency",
        legend: "stable f",
        color: ORANGE,
        shape: Shape::Triangle,
        filled: false,
    },
    StatusStyle {
        status: Stability::Damping,
        key: "damping",
        legend: "stable f, ξ",
        color: GREEN,
        shape: Shape::Square,
        filled: false,
    },
    StatusStyle {
        status: Stability::Stable,
        key: "stable",
        legend: "stable f, ξ, shape",
        color: BLUE,
        shape: Shape::Circle,
        filled: true,
    },
];

/// Stabilization diagram: model order against frequency, one marker per
/// pole by stability status, identified modes and chosen order marked.
pub fn stabilization(prefix: &str, rep: &Representative) -> Fig {
    stabilization_of(prefix, &rep.stabilization, &rep.modes, &[], rep.order)
}

/// Stabilization diagram of `pts` with the model's `modes` (numbered rules),
/// the modes left out of the model (`extra`, grey rules) and the chosen
/// `order` marked.
pub fn stabilization_of(
    prefix: &str,
    pts: &[StabilizationPoint],
    modes: &[ModeShape],
    extra: &[ModeShape],
    order: usize,
) -> Fig {
    let (_, fmax) = finite_range(
        pts.iter()
            .map(|p| &p.frequency_hz)
            .chain(modes.iter().chain(extra).map(|m| &m.frequency_hz)),
    );
    let fmax = if fmax.is_finite() && fmax > 0.0 {
        fmax * 1.05
    } else {
        1.0
    };
    let orders = pts.iter().map(|p| p.order as f64).chain([order as f64]);
    let (omin, omax) = orders.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| {
        (a.min(o), b.max(o))
    });
    let mut layers = vec![];
    for st in STATUS_STYLE {
        let points: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.status == st.status)
            .map(|p| (p.frequency_hz, p.order as f64))
            .collect();
        if !points.is_empty() {
            layers.push(Layer::markers(
                st.key,
                Some(st.legend),
                st.color,
                points,
                st.shape,
                st.filled,
            ));
        }
    }
    for (k, m) in modes.iter().enumerate() {
        layers.push(Layer::vrule(
            &format!("mode-{}", k + 1),
            PURPLE,
            m.frequency_hz,
            Some(format!("{}", k + 1)),
        ));
    }
    for (k, m) in extra.iter().enumerate() {
        layers.push(Layer::vrule(
            &format!("extra-{}", k + 1),
            GREY,
            m.frequency_hz,
            Some(format!("x{}", k + 1)),
        ));
    }
    layers.push(Layer::hrule(
        "order",
        VERMILLION,
        order as f64,
        Some(format!("chosen n = {order}")),
    ));
    let caption = format!(
        "{} poles. A pole is stable in f, ξ or shape when it matches a pole of the next lower order within frameid's tolerances. Dashed vertical lines: identified modes (numbered){}; dashed horizontal line: the chosen order.",
        pts.len(),
        if extra.is_empty() {
            ""
        } else {
            ", grey x1, x2…: modes left out of the model"
        }
    );
    Fig::new(
        Chart {
            id: format!("{prefix}-stabilization"),
            kind: "stabilization".into(),
            title: "Stabilization diagram".into(),
            size: (760, 400),
            x: Axis::linear("Frequency [Hz]", 0.0, fmax),
            y: Axis::integer("Model order", omin, omax),
            layers,
        },
        caption,
    )
}

/// Magnitude and phase of each mode shape (the paper's Fig. 5), identified
/// against truth when given.
pub fn modes(prefix: &str, rep: &Representative) -> Vec<(Fig, Fig)> {
    modes_of(prefix, &rep.modes)
}

/// Magnitude and phase of each of `modes`, numbered from 1.
pub fn modes_of(prefix: &str, modes: &[ModeShape]) -> Vec<(Fig, Fig)> {
    modes
        .iter()
        .enumerate()
        .map(|(k, m)| mode(prefix, k + 1, m))
        .collect()
}

fn mode(prefix: &str, k: usize, m: &ModeShape) -> (Fig, Fig) {
    let truth = m.truth.as_deref().unwrap_or(&[]);
    let ndof = m.shape.len().max(truth.len()).max(1);
    let floors = |s: &[[f64; 2]], f: fn([f64; 2]) -> f64| -> Vec<(f64, f64)> {
        s.iter()
            .enumerate()
            .map(|(i, &c)| ((i + 1) as f64, f(c)))
            .collect()
    };
    let head = format!(
        "Mode {k}: {} Hz, ξ = {} %",
        sig(m.frequency_hz, 4),
        sig(m.damping_ratio * 100.0, 3)
    );
    let mut caption = String::from(
        "Magnitude per floor, scaled so that the largest component is 1 + 0i (cf. the paper's Fig. 5).",
    );
    if let Some(t) = &m.truth {
        match mac(&m.shape, t) {
            Some(v) => caption.push_str(&format!(" MAC with the true shape: {}.", sig(v, 4))),
            None => caption.push_str(" MAC with the true shape: —."),
        }
    }
    let phase_caption = "Phase per floor, shown from −90° to 270° so that in-phase (0°) and anti-phase (180°) floors of a nearly real mode do not jump across ±180°.".to_string();
    let (_, max_mag) = finite_range(
        floors(&m.shape, magnitude)
            .iter()
            .chain(floors(truth, magnitude).iter())
            .map(|p| p.1)
            .collect::<Vec<_>>()
            .iter(),
    );
    let top = if max_mag.is_finite() {
        max_mag.max(1.0) * 1.08
    } else {
        1.08
    };

    let layers_for = |f: fn([f64; 2]) -> f64| {
        let mut layers = vec![];
        layers.push(
            Layer::line("identified", Some("identified"), BLUE, floors(&m.shape, f)).width(2),
        );
        layers.push(Layer::markers(
            "identified",
            Some("identified"),
            BLUE,
            floors(&m.shape, f),
            Shape::Circle,
            true,
        ));
        if !truth.is_empty() {
            layers.push(Layer::line("truth", Some("truth"), VERMILLION, floors(truth, f)).dashed());
            layers.push(Layer::markers(
                "truth",
                Some("truth"),
                VERMILLION,
                floors(truth, f),
                Shape::Square,
                false,
            ));
        }
        layers
    };
    let x = Axis::integer("Floor", 1.0, ndof as f64);
    let magnitude_chart = Chart {
        id: format!("{prefix}-mode-{k}-magnitude"),
        kind: "mode-magnitude".into(),
        title: format!("{head}: magnitude"),
        size: HALF,
        x: x.clone(),
        y: Axis::linear("|φ| [-]", 0.0, top),
        layers: layers_for(magnitude),
    };
    let phase_chart = Chart {
        id: format!("{prefix}-mode-{k}-phase"),
        kind: "mode-phase".into(),
        title: format!("{head}: phase"),
        size: HALF,
        x,
        y: Axis::fixed(
            "Phase [deg]",
            -110.0,
            290.0,
            &[-90.0, 0.0, 90.0, 180.0, 270.0],
        ),
        layers: layers_for(mode_phase_deg),
    };
    let attrs = format!(" data-mode=\"{k}\"");
    let mut a = Fig::new(magnitude_chart, caption.clone());
    a.attrs = attrs.clone();
    let mut b = Fig::new(phase_chart, phase_caption);
    b.attrs = attrs;
    (a, b)
}

/// Measured FRF against the identified model's (and the truth's): magnitude
/// in dB and phase, one pair per output.
pub fn frf(prefix: &str, hit_floor: usize, frfs: &[Frf]) -> Vec<(Fig, Fig)> {
    frfs.iter()
        .enumerate()
        .map(|(j, f)| frf_pair(prefix, j + 1, hit_floor, f))
        .collect()
}

/// Ordinary coherence of the `j`-th FRF (1-based), when it is known.
pub fn coherence(prefix: &str, j: usize, f: &Frf) -> Option<Fig> {
    let gamma = f.coherence.as_ref()?;
    let (fmin, fmax) = finite_range(&f.frequency_hz);
    let points: Vec<(f64, f64)> = f
        .frequency_hz
        .iter()
        .zip(gamma)
        .map(|(&fr, &g)| (fr, g))
        .collect();
    let name = frf_name(j, f);
    let chart = Chart {
        id: format!("{prefix}-frf-{j}-coherence"),
        kind: "frf-coherence".into(),
        title: format!("Coherence {name}"),
        size: HALF,
        x: Axis::linear_exact("Frequency [Hz]", fmin, fmax),
        y: Axis::fixed("γ² [-]", 0.0, 1.05, &[0.0, 0.25, 0.5, 0.75, 1.0]),
        layers: vec![Layer::line("coherence", None, GREEN, points)],
    };
    let mut fig = Fig::new(
        chart,
        format!(
            "Ordinary coherence of {}: 1 where the response is linear in the reference and free of noise; dips at anti-resonances and where noise or unmeasured inputs dominate.",
            escape(&name)
        ),
    );
    fig.attrs = format!(" data-output=\"{j}\"");
    Some(fig)
}

/// The name of an FRF in titles: "output / reference" when the reference is
/// named.
fn frf_name(j: usize, f: &Frf) -> String {
    let out = if f.output.is_empty() {
        format!("output {j}")
    } else {
        f.output.clone()
    };
    match &f.reference {
        Some(r) => format!("{out} / {r}"),
        None => out,
    }
}

fn frf_pair(prefix: &str, j: usize, hit_floor: usize, f: &Frf) -> (Fig, Fig) {
    let (fmin, fmax) = finite_range(&f.frequency_hz);
    let x = Axis::linear_exact("Frequency [Hz]", fmin, fmax);
    let series = |h: &[[f64; 2]], g: fn([f64; 2]) -> f64| -> Vec<(f64, f64)> {
        f.frequency_hz
            .iter()
            .zip(h)
            .map(|(&fr, &c)| (fr, g(c)))
            .collect()
    };
    let truth = f.truth.as_deref().unwrap_or(&[]);
    let all_db: Vec<f64> = [&f.measured[..], &f.identified[..], truth]
        .iter()
        .flat_map(|h| h.iter().map(|&c| db(c)))
        .collect();
    let (lo, hi) = finite_range(&all_db);
    // Deep notches of a noisy estimate would squash the plot; show the top
    // 100 dB and clamp below.
    let lo = if hi.is_finite() {
        lo.max(hi - 100.0)
    } else {
        lo
    };
    let layers = |g: fn([f64; 2]) -> f64, phase: bool| {
        let mut v = vec![];
        let wrap = |l: Layer| if phase { l.break_on_jump(180.0) } else { l };
        if !f.measured.is_empty() {
            v.push(wrap(Layer::line(
                "measured",
                Some("measured"),
                GREY,
                series(&f.measured, g),
            )));
        }
        if !f.identified.is_empty() {
            v.push(wrap(
                Layer::line(
                    "identified",
                    Some("identified model"),
                    BLUE,
                    series(&f.identified, g),
                )
                .width(2),
            ));
        }
        if !truth.is_empty() {
            v.push(wrap(
                Layer::line("truth", Some("truth"), VERMILLION, series(truth, g)).dashed(),
            ));
        }
        v
    };
    let name = frf_name(j, f);
    let title = match &f.reference {
        Some(_) => format!("FRF {name}"),
        None => format!("FRF {name} / force at floor {hit_floor}"),
    };
    let caption = format!(
        "Accelerance of {} to the {}: the {} against the identified model{}.",
        escape(&name),
        if f.reference.is_some() {
            "reference force"
        } else {
            "hammer force"
        },
        if f.reference.is_some() {
            "measured FRF"
        } else {
            "estimate from the records"
        },
        if truth.is_empty() {
            ""
        } else {
            " and the truth"
        }
    );
    let mag = Chart {
        id: format!("{prefix}-frf-{j}-magnitude"),
        kind: "frf-magnitude".into(),
        title: format!("{title}: magnitude"),
        size: HALF,
        x: x.clone(),
        y: Axis::linear("|H| [dB re 1 (m/s²)/N]", lo, hi).clamped(),
        layers: layers(db, false),
    };
    let ph = Chart {
        id: format!("{prefix}-frf-{j}-phase"),
        kind: "frf-phase".into(),
        title: format!("{title}: phase"),
        size: HALF,
        x,
        y: Axis::fixed(
            "Phase [deg]",
            -200.0,
            200.0,
            &[-180.0, -90.0, 0.0, 90.0, 180.0],
        ),
        layers: layers(phase_deg, true),
    };
    let attrs = format!(" data-output=\"{j}\"");
    let mut a = Fig::new(mag, caption.clone());
    a.attrs = attrs.clone();
    let mut b = Fig::new(ph, caption);
    b.attrs = attrs;
    (a, b)
}

/// The y axis label of a quantity: "label [unit]".
pub fn quantity_label(q: &Quantity) -> String {
    let unit = q.unit.trim();
    if unit.is_empty() {
        q.label.clone()
    } else {
        format!("{} [{}]", q.label, unit)
    }
}

/// A y axis shared by all panels of one quantity (or of several quantities
/// drawn together), with the reason when the requested scale was not
/// possible.
pub fn quantity_axis(label: String, qs: &[&Quantity]) -> (Axis, Option<String>) {
    let values: Vec<f64> = qs
        .iter()
        .flat_map(|q| {
            q.median
                .iter()
                .chain(&q.p5)
                .chain(&q.p95)
                .chain(q.bound.iter().flatten())
        })
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) = finite_range(&values);
    let (min_pos, _) = finite_range(values.iter().filter(|v| **v > 0.0));
    let positive = values.iter().filter(|v| **v > 0.0).count();
    let requested = qs.iter().find_map(|q| q.scale);
    let auto_log = positive >= 2 && values.iter().all(|v| *v >= 0.0) && hi / min_pos >= 10.0;
    match requested {
        Some(Scale::Log) if positive == 0 => (
            Axis::linear(label, lo, hi),
            Some("A log scale was requested but no value is positive; the axis is linear.".into()),
        ),
        Some(Scale::Log) => (Axis::log(label, min_pos, hi), None),
        Some(Scale::Linear) => (Axis::linear(label, lo, hi), None),
        None if auto_log => (Axis::log(label, min_pos, hi), None),
        None => (Axis::linear(label, lo, hi), None),
    }
}

fn panel_suffix(axis_name: Option<&str>, panel: &Panel) -> String {
    match (axis_name, &panel.axis_value) {
        (Some(name), Some(v)) => format!(" ({name} = {v})"),
        (None, Some(v)) => format!(" ({v})"),
        _ => String::new(),
    }
}

/// Layers of one quantity: p5-p95 band, median with markers, bound dashed.
fn quantity_layers(
    q: &Quantity,
    levels: &[f64],
    prefix: &str,
    name: &str,
    color: (u8, u8, u8),
    shape: Shape,
) -> Vec<Layer> {
    let key = |s: &str| {
        if prefix.is_empty() {
            s.to_string()
        } else {
            format!("{prefix}-{s}")
        }
    };
    let label = |s: &str| {
        if name.is_empty() {
            s.to_string()
        } else {
            format!("{name} {s}")
        }
    };
    let pts =
        |v: &[f64]| -> Vec<(f64, f64)> { levels.iter().copied().zip(v.iter().copied()).collect() };
    let mut layers = vec![
        Layer::band(
            &key("band"),
            Some(&label("p5–p95")),
            color,
            levels,
            &q.p5,
            &q.p95,
        ),
        Layer::line(
            &key("median"),
            Some(&label("median")),
            color,
            pts(&q.median),
        )
        .width(2),
        Layer::markers(
            &key("median"),
            Some(&label("median")),
            color,
            pts(&q.median),
            shape,
            true,
        ),
    ];
    if let Some(b) = &q.bound {
        // Dark in a single-quantity chart; the quantity's colour when two
        // quantities share a chart, to tell their bounds apart.
        let bound_color = if prefix.is_empty() { DARK } else { color };
        layers.push(
            Layer::line(
                &key("bound"),
                Some(&label("Cramér–Rao bound (std)")),
                bound_color,
                pts(b),
            )
            .dashed(),
        );
    }
    layers
}

fn missing_levels_note(q: &Quantity, levels: &[f64]) -> Option<String> {
    let missing: Vec<String> = levels
        .iter()
        .zip(&q.median)
        .filter(|(_, m)| !m.is_finite())
        .map(|(l, _)| format!("{} %", noise_percent(*l)))
        .collect();
    (!missing.is_empty()).then(|| {
        format!(
            "No median at {} (no successful trial or not computed).",
            missing.join(", ")
        )
    })
}

/// Where a chart of the accuracy section goes: its panel, the shared axes
/// and the chart size.
pub struct PanelView<'a> {
    pub panel: &'a Panel,
    pub axis_name: Option<&'a str>,
    pub x: &'a Axis,
    pub y: &'a Axis,
    pub size: (u32, u32),
}

/// One quantity in one panel.
pub fn quantity(id: String, q: &Quantity, view: &PanelView<'_>) -> Fig {
    let PanelView {
        panel,
        axis_name,
        x,
        y,
        size,
    } = *view;
    let layers = quantity_layers(q, &panel.noise_levels, "", "", BLUE, Shape::Circle);
    // Lines, bands and bounds are explained once for the section; captions
    // carry what is particular to this chart.
    let caption = missing_levels_note(q, &panel.noise_levels)
        .map(|n| escape(&n))
        .unwrap_or_default();
    let mut fig = Fig::new(
        Chart {
            id,
            kind: "quantity".into(),
            title: format!("{}{}", q.label, panel_suffix(axis_name, panel)),
            size,
            x: x.clone(),
            y: y.clone(),
            layers,
        },
        caption,
    );
    fig.attrs = format!(" data-quantity=\"{}\"", escape(&q.key));
    fig
}

/// The MKR and Rayleigh damping errors side by side in one chart, with the
/// refined (maximum-likelihood) estimate's when given.
pub fn damping_pair(
    id: String,
    mkr: &Quantity,
    rayleigh: &Quantity,
    refined: Option<&Quantity>,
    view: &PanelView<'_>,
) -> Fig {
    let PanelView {
        panel,
        axis_name,
        x,
        y,
        size,
    } = *view;
    // Every estimator of the damping matrix shares one Cramér–Rao bound:
    // draw it once, with the last series that carries it.
    let last_with_bound = [Some(mkr), Some(rayleigh), refined]
        .iter()
        .rposition(|q| q.is_some_and(|q| q.bound.is_some()));
    let without_bound = |q: &Quantity, i: usize| -> Quantity {
        let mut q = q.clone();
        if last_with_bound != Some(i) {
            q.bound = None;
        }
        q
    };
    let (mkr_drawn, rayleigh_drawn) = (without_bound(mkr, 0), without_bound(rayleigh, 1));
    let refined_drawn = refined.map(|r| without_bound(r, 2));
    let mut layers = quantity_layers(
        &mkr_drawn,
        &panel.noise_levels,
        "mkr",
        "MKR",
        VERMILLION,
        Shape::Square,
    );
    layers.extend(quantity_layers(
        &rayleigh_drawn,
        &panel.noise_levels,
        "rayleigh",
        "Rayleigh",
        BLUE,
        Shape::Circle,
    ));
    if let Some(r) = &refined_drawn {
        layers.extend(quantity_layers(
            r,
            &panel.noise_levels,
            "refined",
            "refined (ML)",
            GREEN,
            Shape::Triangle,
        ));
    }
    let mut caption = String::from(
        "Damping matrix from MKR (eq. 30) against the Rayleigh fit R = αM + βK (eq. 16–19), same noise and trials. The paper found the MKR damping two orders of magnitude above the Rayleigh one.",
    );
    if refined.is_some() {
        caption.push_str(" Refined: maximum-likelihood output-error fit of M, K and the damping matrix over all hits.");
    }
    for q in [Some(mkr), Some(rayleigh), refined].into_iter().flatten() {
        if let Some(n) = missing_levels_note(q, &panel.noise_levels) {
            caption.push_str(&format!(" {}: {}", escape(&q.label), n));
        }
    }
    let mut fig = Fig::new(
        Chart {
            id,
            kind: "damping-comparison".into(),
            title: format!(
                "Damping matrix: MKR{} Rayleigh{}{}",
                if refined.is_some() { "," } else { " and" },
                if refined.is_some() {
                    " and refined"
                } else {
                    ""
                },
                panel_suffix(axis_name, panel)
            ),
            size,
            x: x.clone(),
            y: y.clone(),
            layers,
        },
        caption,
    );
    fig.attrs = format!(
        " data-quantity=\"{} {}{}\"",
        escape(&mkr.key),
        escape(&rayleigh.key),
        refined
            .map(|r| format!(" {}", escape(&r.key)))
            .unwrap_or_default()
    );
    fig
}

/// The failure rate per noise level of one panel.
/// The y axis of the view is ignored: failure rates always go from 0 to
/// 100 %.
pub fn failure_rate(id: String, view: &PanelView<'_>) -> Fig {
    let PanelView {
        panel,
        axis_name,
        x,
        size,
        ..
    } = *view;
    let pts: Vec<(f64, f64)> = panel
        .noise_levels
        .iter()
        .zip(&panel.failure_rate)
        .map(|(&l, &r)| (l, r * 100.0))
        .collect();
    let layers = vec![
        Layer::line(
            "failure-rate",
            Some("failure rate"),
            VERMILLION,
            pts.clone(),
        )
        .width(2),
        Layer::markers(
            "failure-rate",
            Some("failure rate"),
            VERMILLION,
            pts,
            Shape::Circle,
            true,
        ),
    ];
    let total: usize = panel.trials.iter().sum();
    Fig::new(
        Chart {
            id,
            kind: "failure-rate".into(),
            title: format!("Failed trials{}", panel_suffix(axis_name, panel)),
            size,
            x: x.clone(),
            y: Axis::fixed(
                "Failure rate [%]",
                -4.0,
                104.0,
                &[0.0, 25.0, 50.0, 75.0, 100.0],
            ),
            layers,
        },
        format!("Share of the {total} trials that failed, per noise level; reasons in the table."),
    )
}

/// Trimmed label of a noise level in %.
pub fn level_label(l: f64) -> String {
    format!("{} %", trim(l * 100.0, 3))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(median: Vec<f64>, scale: Option<Scale>) -> Quantity {
        Quantity {
            key: "k".into(),
            label: "l".into(),
            unit: String::new(),
            group: String::new(),
            p5: median.clone(),
            p95: median.clone(),
            median,
            bound: None,
            scale,
        }
    }

    #[test]
    fn relative_errors_get_a_log_axis() {
        let log = |v: Vec<f64>, s| quantity_axis("y".into(), &[&q(v, s)]).0.is_log();
        assert!(log(vec![1e-12, 1e-4, 1e-2], None));
        assert!(
            log(vec![0.0, 0.01, 0.2], None),
            "zeros are clamped, not a reason for linear"
        );
        assert!(!log(vec![0.92, 0.97, 1.0], None), "less than a decade");
        assert!(!log(vec![-1e-3, 1e-2, 1.0], None), "signed values");
        assert!(log(vec![0.92, 0.97, 1.0], Some(Scale::Log)));
        assert!(!log(vec![1e-12, 1e-2], Some(Scale::Linear)));
        let (axis, note) = quantity_axis("y".into(), &[&q(vec![-1.0, 0.0], Some(Scale::Log))]);
        assert!(!axis.is_log() && note.is_some());
    }

    #[test]
    fn modal_assurance_criterion() {
        let a = [[1.0, 0.0], [0.62, 0.01]];
        assert!((mac(&a, &a).unwrap() - 1.0).abs() < 1e-15);
        // Invariant to a complex scale factor.
        let b: Vec<[f64; 2]> = a.iter().map(|c| [-c[1] * 2.0, c[0] * 2.0]).collect();
        assert!((mac(&a, &b).unwrap() - 1.0).abs() < 1e-12);
        let orthogonal = [[0.62, 0.0], [-1.0, 0.0]];
        assert!(mac(&[[1.0, 0.0], [0.62, 0.0]], &orthogonal).unwrap() < 1e-12);
        assert_eq!(mac(&[], &a), None);
        assert_eq!(mac(&[[0.0, 0.0]], &[[0.0, 0.0]]), None);
    }

    #[test]
    fn mode_phase_keeps_anti_phase_away_from_the_wrap() {
        assert!((mode_phase_deg([-1.0, -1e-3]) - 180.06).abs() < 0.01);
        assert!((mode_phase_deg([-1.0, 1e-3]) - 179.94).abs() < 0.01);
        assert!((mode_phase_deg([0.0, -1.0]) - (-90.0)).abs() < 1e-12);
        assert!(mode_phase_deg([f64::NAN, 0.0]).is_nan());
    }
}
