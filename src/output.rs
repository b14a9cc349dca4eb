//! Rendering of outcomes: readable tables on the terminal of the
//! documents in `study::document` (their JSON is serde's), the sweep
//! summary and the FRF summary. Nothing here computes; everything is
//! formatting of library results.

use std::fmt::Write as _;

use nalgebra::DMatrix;
use records::numfmt::sig;
use study::document::{
    FrfIdentifyReport, IdentifyReport, PointReport, RefinedReport, WithoutSensors,
};
use study::score::{FrfScore, MatrixEstimate, ScoreKey};
use study::sweep::Summary;

/// A matrix as aligned rows with 5 significant digits.
pub fn matrix(title: &str, m: &DMatrix<f64>) -> String {
    let mut s = format!("{title}\n");
    for i in 0..m.nrows() {
        s.push_str("  ");
        for j in 0..m.ncols() {
            s.push_str(&format!("{:>13}", sig(m[(i, j)], 5)));
        }
        s.push('\n');
    }
    s
}

/// `value ± std` with the std to 2 significant digits and the value to
/// the same decimal place (at least `digits` significant digits without a
/// std).
pub fn plus_minus(value: f64, std: Option<f64>, digits: usize) -> String {
    match std {
        Some(s) if s.is_finite() && s > 0.0 && value.is_finite() => {
            let std_mag = s.log10().floor() as i32;
            let decimals = (1 - std_mag).max(0) as usize;
            let vmag = value.abs().max(s).log10().floor() as i32;
            if (-3..6).contains(&vmag) && decimals <= 8 {
                format!("{value:.decimals$} ± {s:.decimals$}")
            } else {
                format!("{} ± {}", sig(value, digits), sig(s, 2))
            }
        }
        _ => sig(value, digits),
    }
}

/// A matrix as aligned rows of `value ± std` (or plain values).
pub fn matrix_table(title: &str, value: &[Vec<f64>], std: Option<&[Vec<f64>]>) -> String {
    let cells: Vec<Vec<String>> = value
        .iter()
        .enumerate()
        .map(|(i, row)| {
            row.iter()
                .enumerate()
                .map(|(j, &v)| plus_minus(v, std.map(|s| s[i][j]), 5))
                .collect()
        })
        .collect();
    let width = cells
        .iter()
        .flatten()
        .map(|c| c.chars().count())
        .max()
        .unwrap_or(0)
        .max(11)
        + 2;
    let mut out = format!("{title}\n");
    for row in &cells {
        out.push_str("  ");
        for c in row {
            out.push_str(&format!("{c:>width$}"));
        }
        out.push('\n');
    }
    out
}

/// Readable tables of an outcome document.
pub trait Human {
    /// The text for the terminal.
    fn human(&self) -> String;
}

impl Human for RefinedReport {
    /// Readable tables (value ± standard error).
    fn human(&self) -> String {
        let mut out = String::from("\nRefined by maximum likelihood (value ± standard error)\n");
        for m in &self.modes {
            out.push_str(&format!(
                "  f = {} Hz, xi = {} %\n",
                plus_minus(m.frequency_hz, Some(m.frequency_std_hz), 6),
                plus_minus(
                    100.0 * m.damping_ratio,
                    Some(100.0 * m.damping_ratio_std),
                    4
                )
            ));
        }
        out.push_str(&matrix_table(
            "Mass M [kg]",
            &self.mass,
            Some(&self.mass_std),
        ));
        out.push_str(&matrix_table(
            "Stiffness K [N/m]",
            &self.stiffness,
            Some(&self.stiffness_std),
        ));
        out.push_str(&matrix_table(
            "Damping [N s/m]",
            &self.damping,
            Some(&self.damping_std),
        ));
        if let Some(model) = &self.noise_model {
            out.push_str(&format!("  noise model of the FRF values: {model}\n"));
        }
        if self.noise_outputs.is_empty() {
            out.push_str(&format!(
                "  {} iterations, stopped on {} (cost {} -> {})\n",
                self.iterations,
                self.stop,
                sig(self.initial_cost, 4),
                sig(self.cost, 4)
            ));
            return out;
        }
        out.push_str(&format!(
            "  noise std: outputs {}, input {}; {} iterations, stopped on {} (cost {} -> {})\n",
            self.noise_outputs
                .iter()
                .map(|x| sig(*x, 3))
                .collect::<Vec<_>>()
                .join(", "),
            self.noise_inputs
                .iter()
                .map(|x| sig(*x, 3))
                .collect::<Vec<_>>()
                .join(", "),
            self.iterations,
            self.stop,
            sig(self.initial_cost, 4),
            sig(self.cost, 4)
        ));
        out
    }
}

impl Human for IdentifyReport {
    /// Readable tables.
    fn human(&self) -> String {
        let s = &self.source;
        let mut out = String::new();
        if s.realization {
            out.push_str(&format!(
                "realization {} (dt = {} s)\n",
                s.files.join(", "),
                sig(s.dt_s, 6)
            ));
        } else {
            let samples = if self.shortest > 0 && self.shortest < s.samples {
                format!("{}-{}", self.shortest, s.samples)
            } else {
                s.samples.to_string()
            };
            out.push_str(&format!(
                "{} record(s), {samples} samples, dt = {} s ({} Hz)\n",
                s.hits,
                sig(s.dt_s, 6),
                sig(1.0 / s.dt_s, 6)
            ));
        }
        if let Some(d) = &self.decimation {
            let filter = d.filter.as_ref().map_or(String::new(), |f| {
                format!(
                    "; zero-phase Kaiser FIR, {} taps, pass band to {} Hz, stop band from {} Hz at {} dB",
                    f.taps,
                    sig(f.passband_hz, 4),
                    sig(f.stopband_hz, 4),
                    f.attenuation_db
                )
            });
            out.push_str(&format!(
                "decimation: factor {} ({}), {} Hz to {} Hz{filter}: {}\n",
                d.factor,
                d.chosen,
                sig(d.original_rate_hz, 6),
                sig(d.rate_hz, 6),
                d.reason
            ));
        }
        if let Some(i) = &self.initial_state {
            out.push_str(&format!(
                "initial state: {} ({}): {}\n",
                match i.assumed {
                    ident::InitialState::AtRest => "at rest",
                    _ => "unknown",
                },
                i.chosen,
                i.reason
            ));
        }
        out.push_str(&format!(
            "inputs: {}; outputs (DOF order): {}; collocated: {} / {}; intersample: {}\n",
            s.inputs.join(", "),
            s.outputs.join(", "),
            s.outputs[s.collocated.output],
            s.inputs[s.collocated.input],
            self.intersample
        ));
        if let Some(o) = &self.observer {
            out.push_str(&format!(
                "OKID: observer order {}, input leads {}, rank {}/{}, rcond {:.1e}, relative residual {:.2e}\n",
                o.order, o.leads, o.rank, o.unknowns, o.rcond, o.relative_residual
            ));
        }
        if !self.hit_quality.is_empty() {
            out.push_str(&self.quality_table());
            out.push_str(&self.band_snr_table());
        }
        out.push_str(&format!("model order {}\n", self.model_order));
        let u = self.uncertainty.as_ref();
        match (u, &self.uncertainty_skipped) {
            (Some(u), _) if u.groups < u.hits => out.push_str(&format!(
                "error bars: +- one standard error, {} over {} hits in {} groups ({} resamples at model order {})\n",
                u.method, u.hits, u.groups, u.resamples, u.model_order
            )),
            (Some(u), _) => out.push_str(&format!(
                "error bars: +- one standard error, {} over {} hits ({} resamples at model order {})\n",
                u.method, u.hits, u.resamples, u.model_order
            )),
            (None, Some(why)) if !s.realization => {
                out.push_str(&format!("no error bars: {why}\n"));
            }
            _ => {}
        }
        out.push_str("\nModes\n");
        let rows: Vec<[String; 8]> = self
            .modes
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let k = self.mkr_modes.iter().position(|&j| j == i);
                let f_std = u.zip(k).map(|(u, k)| u.frequencies_hz.std[k]);
                let xi_std = u.zip(k).map(|(u, k)| 100.0 * u.damping_ratios.std[k]);
                [
                    format!("{}", i + 1),
                    plus_minus(m.frequency_hz, f_std, 6),
                    plus_minus(100.0 * m.damping_ratio, xi_std, 4),
                    m.emac.map_or("-".to_string(), |e| format!("{e:.3}")),
                    format!("{:.3}", m.mpc),
                    format!("{:.3}", m.cmi),
                    if m.structural { "yes" } else { "no" }.to_string(),
                    if m.used { "yes" } else { "" }.to_string(),
                ]
            })
            .collect();
        let head = [
            "#",
            "f [Hz]",
            "xi [%]",
            "EMAC",
            "MPC",
            "CMI",
            "structural",
            "used",
        ];
        let widths: Vec<usize> = (0..head.len())
            .map(|c| {
                rows.iter()
                    .map(|r| r[c].chars().count())
                    .chain([head[c].len()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        out.push(' ');
        for (c, h) in head.iter().enumerate() {
            out.push_str(&format!(" {h:>w$}", w = widths[c] + 1));
        }
        out.push('\n');
        for r in &rows {
            out.push(' ');
            for (c, cell) in r.iter().enumerate() {
                out.push_str(&format!(" {cell:>w$}", w = widths[c] + 1));
            }
            out.push('\n');
        }
        out.push_str("\nMode shapes of the modes used (outputs, magnitude and phase in degrees)\n");
        for m in self.modes.iter().filter(|m| m.used) {
            out.push_str(&format!("  {} Hz:", sig(m.frequency_hz, 5)));
            for (name, z) in s.outputs.iter().zip(&m.mode_shape) {
                let mag = z[0].hypot(z[1]);
                let ph = z[1].atan2(z[0]).to_degrees();
                out.push_str(&format!("  {name} {} at {:.1} deg", sig(mag, 4), ph));
            }
            out.push('\n');
        }
        out.push_str(&format!(
            "\nRayleigh: alpha = {} 1/s, beta = {} s\n\n",
            plus_minus(self.rayleigh.alpha, u.map(|u| u.rayleigh_alpha.std), 5),
            plus_minus(self.rayleigh.beta, u.map(|u| u.rayleigh_beta.std), 5)
        ));
        match u {
            Some(u) => {
                out.push_str(&matrix_table("Mass M [kg]", &self.mass, Some(&u.mass.std)));
                out.push_str(&matrix_table(
                    "Stiffness K [N/m]",
                    &self.stiffness,
                    Some(&u.stiffness.std),
                ));
                out.push_str(&matrix_table(
                    "Damping, MKR [N s/m]",
                    &self.damping_mkr,
                    Some(&u.damping_mkr.std),
                ));
                out.push_str(&matrix_table(
                    "Damping, Rayleigh alpha M + beta K [N s/m]",
                    &self.damping_rayleigh,
                    Some(&u.damping_rayleigh.std),
                ));
            }
            None => {
                let m = |rows: &Vec<Vec<f64>>| {
                    DMatrix::from_fn(rows.len(), rows.len(), |i, j| rows[i][j])
                };
                out.push_str(&matrix("Mass M [kg]", &m(&self.mass)));
                out.push_str(&matrix("Stiffness K [N/m]", &m(&self.stiffness)));
                out.push_str(&matrix("Damping, MKR [N s/m]", &m(&self.damping_mkr)));
                out.push_str(&matrix(
                    "Damping, Rayleigh alpha M + beta K [N s/m]",
                    &m(&self.damping_rayleigh),
                ));
            }
        }
        out.push_str(&format!(
            "\nSecond-order consistency ||W W^T|| / ||W L W^T|| = {:.3e} (0 for an exact second-order system)\n",
            self.consistency
        ));
        if self.polarity_flipped {
            out.push_str("Input polarity was inverted and has been flipped.\n");
        }
        if let Some(r) = &self.refined {
            out.push_str(&r.human());
        }
        if let Some(w) = &self.without_sensors {
            out.push_str(&w.human());
        }
        if !self.warnings.is_empty() {
            out.push_str("\nWarnings\n");
            for w in &self.warnings {
                out.push_str(&format!("  - {w}\n"));
            }
        }
        out
    }
}

/// The tables of the hits in the human output of the time route.
trait HitTables {
    fn band_snr_table(&self) -> String;
    fn quality_table(&self) -> String;
}

impl HitTables for IdentifyReport {
    /// The SNR per octave band of continuous records (empty without any).
    fn band_snr_table(&self) -> String {
        let mut out = String::new();
        for q in &self.hit_quality {
            for ch in &q.snr_bands {
                if out.is_empty() {
                    out.push_str(&format!(
                        "SNR per octave band from the coherence, dB (gamma^2 / (1 - gamma^2); * below {} dB, ( ) not excited by the force)\n",
                        records::quality::QualitySettings::default().min_band_snr_db
                    ));
                }
                let cells: Vec<String> = ch
                    .bands
                    .iter()
                    .map(|b| {
                        let v = format!(
                            "{}-{} Hz {:.0}{}",
                            sig(b.low_hz, 3),
                            sig(b.high_hz, 3),
                            b.snr_db,
                            if b.low { "*" } else { "" }
                        );
                        if b.excited { v } else { format!("({v})") }
                    })
                    .collect();
                out.push_str(&format!(
                    "  {} {}: {}\n",
                    q.file,
                    ch.channel,
                    cells.join(", ")
                ));
            }
        }
        if !out.is_empty() {
            out.push('\n');
        }
        out
    }

    /// The hit quality table of the human output.
    fn quality_table(&self) -> String {
        let names: Vec<&str> = self
            .hit_quality
            .first()
            .map(|q| q.channels.iter().map(|c| c.name.as_str()).collect())
            .unwrap_or_default();
        let head = [
            "hit".to_string(),
            "file".to_string(),
            "t [s]".to_string(),
            "2nd pulse".to_string(),
            "fall [dB]".to_string(),
            format!("SNR [dB] {}", names.join("/")),
            "tail".to_string(),
            "checks".to_string(),
        ];
        let rows: Vec<Vec<String>> = self
            .hit_quality
            .iter()
            .map(|q| {
                let p = q.pulse.as_ref();
                let snr: Vec<String> = q
                    .channels
                    .iter()
                    .map(|c| c.snr_db.map_or("-".to_string(), |v| format!("{v:.0}")))
                    .collect();
                let mut checks: Vec<&str> = q.flags.iter().map(|f| f.check.label()).collect();
                checks.extend(
                    self.inconsistent_hits
                        .iter()
                        .filter(|f| f.record + 1 == q.hit)
                        .map(|f| f.kind.label()),
                );
                let mut checks_text = if checks.is_empty() {
                    "ok".to_string()
                } else {
                    let mut v: Vec<&str> = Vec::new();
                    for c in checks {
                        if !v.contains(&c) {
                            v.push(c);
                        }
                    }
                    v.join(", ")
                };
                if self.dropped_positions.contains(&(q.hit - 1)) {
                    checks_text.push_str(" (dropped)");
                }
                vec![
                    q.hit.to_string(),
                    q.file.clone(),
                    q.hit_time_s.map_or("-".into(), |t| format!("{t:.3}")),
                    p.map_or("-".into(), |p| format!("{:.2}", p.double_hit_ratio)),
                    p.map_or("-".into(), |p| format!("{:.1}", p.spectrum_drop_db)),
                    snr.join("/"),
                    q.max_tail_ratio()
                        .map_or("-".into(), |t| format!("{:.3}", t)),
                    checks_text,
                ]
            })
            .collect();
        let widths: Vec<usize> = (0..head.len())
            .map(|c| {
                rows.iter()
                    .map(|r| r[c].chars().count())
                    .chain([head[c].chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::from(
            "\nHit quality (2nd pulse: second force pulse over the first; fall: force spectrum over the band; tail: end RMS over peak)\n",
        );
        let line = |cells: &[String]| -> String {
            let mut l = String::from(" ");
            for (c, cell) in cells.iter().enumerate() {
                if c == 1 || c + 1 == cells.len() {
                    l.push_str(&format!("  {cell:<w$}", w = widths[c]));
                } else {
                    l.push_str(&format!("  {cell:>w$}", w = widths[c]));
                }
            }
            l.trim_end().to_string() + "\n"
        };
        out.push_str(&line(&head));
        for r in &rows {
            out.push_str(&line(r));
        }
        out.push('\n');
        out
    }
}

/// Median errors per noise level: frequencies and damping ratios (worst
/// mode), M, K and the damping estimates (MKR, Rayleigh and, if the sweep
/// refines, maximum likelihood).
pub fn summary_table(s: &Summary) -> String {
    let refined = s.plan.scenario.identification.refine;
    let mut out = String::from(
        "  axis         noise   fail  f err    xi err   M err    K err    R(MKR)   R(Rayl.)",
    );
    out.push_str(if refined {
        "  R(ML)    (medians, worst mode)\n"
    } else {
        "  (medians, worst mode)\n"
    });
    let dofs = s.plan.scenario.structure.dofs();
    for l in &s.levels {
        let med = |key: ScoreKey| l.scores.get(&key).and_then(|st| st.median);
        let worst = |key: fn(usize) -> ScoreKey| {
            (1..=dofs)
                .filter_map(|j| med(key(j)))
                .fold(None, |a: Option<f64>, x| Some(a.map_or(x, |a| a.max(x))))
        };
        let cell = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.2e}"));
        let matrix = |m| cell(med(ScoreKey::Matrix(m)));
        out.push_str(&format!(
            "  {:<10} {:>6}%  {:>4}  {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
            l.axis_value
                .as_ref()
                .map(ToString::to_string)
                .unwrap_or_default(),
            sig(100.0 * l.noise, 3),
            format!("{:.0}%", 100.0 * l.failure_rate),
            cell(worst(|mode| ScoreKey::Frequency {
                mode,
                refined: false
            })),
            cell(worst(|mode| ScoreKey::DampingRatio {
                mode,
                refined: false
            })),
            matrix(MatrixEstimate::Mass),
            matrix(MatrixEstimate::Stiffness),
            matrix(MatrixEstimate::DampingMkr),
            matrix(MatrixEstimate::DampingRayleigh),
        ));
        if refined {
            out.push_str(&format!(" {:>8}", matrix(MatrixEstimate::DampingRefined)));
        }
        out.push('\n');
        if s.plan.scenario.identification.route.frf() {
            let frf = |key: FrfScore| med(ScoreKey::Frf(key));
            let worst_frf = |key: fn(usize) -> FrfScore| {
                (1..=dofs)
                    .filter_map(|j| frf(key(j)))
                    .fold(None, |a: Option<f64>, x| Some(a.map_or(x, |a| a.max(x))))
            };
            out.push_str(&format!(
                "  {:<10} {:>7}  {:>4}  {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}\n",
                "  FRF route",
                "",
                "",
                cell(worst_frf(|mode| FrfScore::Frequency { mode })),
                cell(worst_frf(|mode| FrfScore::DampingRatio { mode })),
                cell(frf(FrfScore::Matrix(MatrixEstimate::Mass))),
                cell(frf(FrfScore::Matrix(MatrixEstimate::Stiffness))),
                cell(frf(FrfScore::Matrix(MatrixEstimate::DampingMkr))),
                cell(frf(FrfScore::Matrix(MatrixEstimate::DampingRayleigh))),
            ));
        }
    }
    out
}

/// Readable text of what `frameid frf` did, written into `dir`.
pub fn frf_summary_text(this: &study::frfs::FrfSummary, dir: &std::path::Path) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "FRFs of {} record(s) ({}): {} of {} to {}, {} average(s), {} lines {}-{} Hz every {} Hz",
        this.hits_used,
        this.excitation,
        this.estimator,
        this.outputs.join(", "),
        this.references.join(", "),
        this.averages,
        this.lines,
        sig(this.band_hz[0], 5),
        sig(this.band_hz[1], 5),
        sig(this.resolution_hz, 5)
    );
    if let Some(tau) = this.exponential_tau_s {
        let _ = writeln!(
            s,
            "exponential window: tau = {} s (it adds a damping ratio of 1 / (tau omega), e.g. {} % at 10 Hz; frameid identify removes it: the UFF files state it, a CSV file does not: pass --exponential-tau {} with it)",
            sig(tau, 4),
            sig(100.0 / (tau * 2.0 * std::f64::consts::PI * 10.0), 3),
            tau
        );
    }
    let _ = writeln!(
        s,
        "coherence: lowest {}, median {}",
        sig(this.coherence_min, 3),
        sig(this.coherence_median, 3)
    );
    if !this.dropped.is_empty() {
        let _ = writeln!(s, "dropped: {}", this.dropped.join(", "));
    }
    for w in &this.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    let _ = writeln!(
        s,
        "wrote {} in {}",
        this.written
            .iter()
            .chain(std::iter::once(&"frf.json".to_string()))
            .cloned()
            .collect::<Vec<_>>()
            .join(", "),
        dir.display()
    );
    s
}

impl Human for FrfIdentifyReport {
    /// Readable tables.
    fn human(&self) -> String {
        let s = &self.source;
        let names = |p: &[PointReport]| {
            p.iter()
                .map(|p| match (p.node, p.direction) {
                    (Some(n), Some(d)) => {
                        format!("{} ({n}:{})", p.name, records::direction_label(d))
                    }
                    _ => p.name.clone(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut out = format!(
            "FRFs ({}) from {}: {} lines, {}-{} Hz, {} average(s), coherence {}\nresponses (DOF order): {}; references: {}; collocated: {} / {}\n",
            s.quantity,
            s.files.join(", "),
            s.lines,
            sig(s.band_hz[0], 5),
            sig(s.band_hz[1], 5),
            s.averages.map_or("unknown".to_string(), |n| n.to_string()),
            if s.coherence { "given" } else { "not given" },
            names(&s.outputs),
            names(&s.references),
            s.outputs
                .get(s.collocated.output)
                .map_or("?", |p| p.name.as_str()),
            s.references
                .get(s.collocated.input)
                .map_or("?", |p| p.name.as_str()),
        );
        out.push_str(&format!("pLSCF order {}\n", self.model_order));
        let u = self.uncertainty.as_ref();
        match (u, &self.uncertainty_skipped) {
            (Some(u), _) => out.push_str(&format!(
                "error bars: +- one standard error, {}\n",
                u.method
            )),
            (None, Some(why)) => out.push_str(&format!("no error bars: {why}\n")),
            _ => {}
        }
        out.push_str("\nModes\n");
        let mut used = 0;
        for (i, m) in self.modes.iter().enumerate() {
            let k = m.used.then_some(used);
            used += usize::from(m.used);
            let f_std = u
                .zip(k)
                .and_then(|(u, k)| u.frequencies_hz_std.get(k).copied());
            let xi_std = u
                .zip(k)
                .and_then(|(u, k)| u.damping_ratios_std.get(k).map(|s| 100.0 * s));
            out.push_str(&format!(
                "  {:>2}  f = {} Hz  xi = {} %  MPC {:.3}{}\n",
                i + 1,
                plus_minus(m.frequency_hz, f_std, 6),
                plus_minus(100.0 * m.damping_ratio, xi_std, 4),
                m.mpc,
                if m.used { "  used" } else { "  out of model" }
            ));
        }
        for r in &self.rejected_modes {
            out.push_str(&format!(
                "  rejected pole {} Hz ({} %): {}\n",
                sig(r.frequency_hz, 5),
                sig(100.0 * r.damping_ratio, 3),
                r.reason
            ));
        }
        if let Some(tau) = self.exponential_tau_s {
            out.push_str(&format!(
                "exponential window tau = {} s removed from the modes\n",
                sig(tau, 4)
            ));
        }
        for c in &self.checks.reciprocity {
            out.push_str(&format!(
                "reciprocity {} against {}: {} %\n",
                c.a,
                c.b,
                sig(100.0 * c.relative_difference, 3)
            ));
        }
        out.push_str(&format!(
            "\nRayleigh: alpha = {} 1/s, beta = {} s\n\n",
            sig(self.rayleigh.alpha, 5),
            sig(self.rayleigh.beta, 5)
        ));
        out.push_str(&matrix_table(
            "Mass M [kg]",
            &self.mass,
            u.map(|u| u.mass_std.as_slice()),
        ));
        out.push_str(&matrix_table(
            "Stiffness K [N/m]",
            &self.stiffness,
            u.map(|u| u.stiffness_std.as_slice()),
        ));
        out.push_str(&matrix_table(
            "Damping, MKR [N s/m]",
            &self.damping_mkr,
            u.map(|u| u.damping_mkr_std.as_slice()),
        ));
        out.push_str(&matrix_table(
            "Damping, Rayleigh alpha M + beta K [N s/m]",
            &self.damping_rayleigh,
            u.map(|u| u.damping_rayleigh_std.as_slice()),
        ));
        out.push_str(&format!(
            "\nSecond-order consistency ||W W^T|| / ||W L W^T|| = {:.3e}\n",
            self.consistency
        ));
        if self.polarity_flipped {
            out.push_str("Input polarity was inverted and has been flipped.\n");
        }
        if let Some(r) = &self.refined {
            out.push_str(&r.human());
        }
        if let Some(w) = &self.without_sensors {
            out.push_str(&w.human());
        }
        if !self.warnings.is_empty() {
            out.push_str("\nWarnings\n");
            for w in &self.warnings {
                out.push_str(&format!("  - {w}\n"));
            }
        }
        out
    }
}

impl Human for WithoutSensors {
    /// Readable table.
    fn human(&self) -> String {
        let m = |rows: &Vec<Vec<f64>>| DMatrix::from_fn(rows.len(), rows.len(), |i, j| rows[i][j]);
        let mut out = format!(
            "\nWithout the sensors ({} kg)\n",
            self.sensor_mass_kg
                .iter()
                .map(|s| sig(*s, 4))
                .collect::<Vec<_>>()
                .join(", ")
        );
        out.push_str(&matrix("Mass M without the sensors [kg]", &m(&self.mass)));
        if let Some(r) = &self.refined_mass {
            out.push_str(&matrix("Refined mass M without the sensors [kg]", &m(r)));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plus_minus_rounds_to_the_std() {
        assert_eq!(plus_minus(630.4392, Some(0.3312), 5), "630.44 ± 0.33");
        assert_eq!(plus_minus(0.29131, Some(0.00012), 5), "0.29131 ± 0.00012");
        assert_eq!(plus_minus(-425.83, Some(2.4), 5), "-425.8 ± 2.4");
        assert_eq!(plus_minus(630.4392, None, 5), "630.44");
        assert_eq!(plus_minus(3.2283e-5, Some(1.1e-7), 5), "3.2283e-5 ± 1.1e-7");
    }
}
