//! Exact sampled responses to half-sine hammer pulses.
//!
//! Two acquisition models:
//! - [`AnalyzerEngine`]: structure, half-sine pulse generator and one analog
//!   anti-alias filter per channel form one continuous linear system whose
//!   state is known exactly (matrix exponentials) on the internal ADC
//!   grid; the decimation FIR is then applied. Only the few internal
//!   samples during the pulse are evaluated (the half-sine response in
//!   closed form); the FIR sum over the free response after the pulse is a
//!   tabulated row `H_j` times the state at the pulse end, and once a
//!   window lies entirely after the pulse the output is `G z` with the
//!   state advancing one analysis step at a time, plant and filter
//!   transients decoupled. [`AnalyzerEngine::reference_response`] computes
//!   the same thing sample by sample on the whole internal grid (the test
//!   oracle).
//! - [`HeldEngine`]: the force is held constant over each analysis sample at
//!   its mean value over the sample (zero-order hold) and the structure's
//!   response is the exact ZOH discretization; no analyzer chain.
//!
//! Channel 0 of every response is the force, channel 1 + j the absolute
//! acceleration of DOF j.

use nalgebra::{DMatrix, DVector};

use crate::analyzer::{AnalyzerDesign, butterworth, kaiser_lowpass};
use crate::hammer::Pulse;
use crate::model::Model;
use crate::rig::Plant;

/// Sampled channels: `channels[c][n]`, c = 0 force, 1.. accelerations.
pub type Channels = Vec<Vec<f64>>;

/// Exact analyzer-chain response engine for one model, hit floor, pulse
/// duration and sampling; build once, call for many hits.
///
/// Per pulse, only the few internal samples during the pulse are stepped
/// explicitly. Every FIR window that reaches past the pulse end takes the
/// free response after the end in closed form: with `z_e` the state at the
/// first internal instant `i_e` at or after the end and `j = i_e - (n d - L)`
/// the window position of that instant, the free part of output `n` is
/// `H_j z_e`, `H_j = C_out sum_{k >= j} h_k Phi^(k - j)` (tabulated once for
/// every `j`). Windows that start after the end (most of the record) follow
/// the free response at the analysis rate: plant and filters decoupled
/// (`FreeTail`) so that a step costs a few dozen operations.
#[derive(Debug, Clone)]
pub struct AnalyzerEngine {
    n_out: usize,
    samples: usize,
    oversampling: usize,
    dt_internal_s: f64,
    pulse_duration_s: f64,
    a_on: DMatrix<f64>,
    a_off: DMatrix<f64>,
    c_out: DMatrix<f64>,
    phi_on: DMatrix<f64>,
    phi_off: DMatrix<f64>,
    taps: Vec<f64>,
    /// Plant states (they start at `PLANT_AT`).
    plant_states: usize,
    /// Order of each channel's analog filter; channel c's filter states
    /// start at `filters_at + c * filter_order`.
    filter_order: usize,
    filters_at: usize,
    /// `H_j` restricted to what channel c reads (plant states, then its
    /// filter's states): `fir_folded[(j * n_out + c) * w ..][..w]`,
    /// `w = plant_states + filter_order`, for `j = 0..taps.len()`.
    fir_folded: Vec<f64>,
    tail: FreeTail,
}

/// Index of the first plant state (after the two pulse-generator states).
const PLANT_AT: usize = 2;

impl AnalyzerEngine {
    /// `input_dof` is zero-based; `dt_s` the analysis sample interval.
    pub fn new(
        model: &Model,
        input_dof: usize,
        pulse_duration_s: f64,
        dt_s: f64,
        samples: usize,
        design: &AnalyzerDesign,
    ) -> Self {
        Self::with_plant(
            &Plant::bare(model, input_dof),
            pulse_duration_s,
            dt_s,
            samples,
            design,
        )
    }

    /// The engine for a plant with rig effects ([`Plant::new`]); with the
    /// bare plant this is exactly [`AnalyzerEngine::new`].
    pub fn with_plant(
        plant: &Plant,
        pulse_duration_s: f64,
        dt_s: f64,
        samples: usize,
        design: &AnalyzerDesign,
    ) -> Self {
        let n_out = plant.channels();
        let xs = PLANT_AT; // plant states start after the two generator states
        let chain = ChainSystem::new(plant, design, xs);
        let a_off = chain.a;
        // During the pulse: generator s1' = w s2, s2' = -w s1 with
        // s(t0) = [0, P], so s1 = P sin(w (t - t0)) is the force u.
        let w = std::f64::consts::PI / pulse_duration_s;
        let mut a_on = a_off.clone();
        a_on[(0, 1)] = w;
        a_on[(1, 0)] = -w;
        let np = plant.states();
        for r in 0..np {
            a_on[(xs + r, 0)] = plant.b[(r, 0)];
        }
        let (fs, nf) = (chain.filters_at, chain.filter_order);
        for ch in 0..n_out {
            let o = fs + ch * nf;
            let feedthrough = plant.d[(ch, 0)];
            for r in 0..nf {
                a_on[(o + r, 0)] += chain.filter_b[(r, 0)] * feedthrough;
            }
        }
        let c_out = chain.c_out;
        let dt_internal_s = dt_s / design.oversampling as f64;
        let phi_on = balanced_exp(&(&a_on * dt_internal_s));
        let phi_off = balanced_exp(&(&a_off * dt_internal_s));
        let taps = kaiser_lowpass(
            design.internal_rate_hz,
            design.passband_hz,
            design.stopband_hz,
            design.stopband_attenuation_db,
        );
        // H_j = h_j C_out + H_{j+1} Phi_off backwards from H_K = 0. Channel c
        // reads its own filter's states only, and the free dynamics couple
        // the plant into every filter but no filter into anything else, so
        // row c of H_j has non-zeros on the plant's and filter c's states.
        let width = np + nf;
        let k_len = taps.len();
        let mut fir_folded = vec![0.0; k_len * n_out * width];
        let phi_pp = phi_off.view((xs, xs), (np, np)).into_owned();
        for c in 0..n_out {
            let o = fs + c * nf;
            let phi_fp = phi_off.view((o, xs), (nf, np)).into_owned();
            let phi_ff = phi_off.view((o, o), (nf, nf)).into_owned();
            let out_row = chain.filter_c.clone();
            let mut next = vec![0.0; width];
            for j in (0..k_len).rev() {
                let at = |j: usize| (j * n_out + c) * width;
                if j + 1 < k_len {
                    let prev = &fir_folded[at(j + 1)..at(j + 1) + width];
                    for col in 0..np {
                        let mut acc = 0.0;
                        for r in 0..np {
                            acc += prev[r] * phi_pp[(r, col)];
                        }
                        for r in 0..nf {
                            acc += prev[np + r] * phi_fp[(r, col)];
                        }
                        next[col] = acc;
                    }
                    for col in 0..nf {
                        let mut acc = 0.0;
                        for r in 0..nf {
                            acc += prev[np + r] * phi_ff[(r, col)];
                        }
                        next[np + col] = acc;
                    }
                } else {
                    next.iter_mut().for_each(|v| *v = 0.0);
                }
                for r in 0..nf {
                    next[np + r] += taps[j] * out_row[(0, r)];
                }
                fir_folded[at(j)..at(j) + width].copy_from_slice(&next);
            }
        }
        let tail = FreeTail::new(
            &a_off,
            &fir_folded[..n_out * width],
            FreeLayout {
                n_out,
                plant_states: np,
                filter_order: nf,
                filters_at: fs,
            },
            dt_internal_s,
            dt_s,
            &PulseInput {
                a_on: &a_on,
                filter_c: chain.filter_c.as_slice(),
                duration_s: pulse_duration_s,
            },
        );
        AnalyzerEngine {
            n_out,
            samples,
            oversampling: design.oversampling,
            dt_internal_s,
            pulse_duration_s,
            a_on,
            a_off,
            c_out,
            phi_on,
            phi_off,
            taps,
            plant_states: np,
            filter_order: nf,
            filters_at: fs,
            fir_folded,
            tail,
        }
    }

    /// Half-length L of the decimation FIR (taps span internal samples
    /// -L..=L around each analysis instant).
    pub fn fir_half_length(&self) -> usize {
        self.taps.len() / 2
    }

    /// Noise-free channels for the given pulses (superposition: every pulse
    /// is simulated from rest and the responses are added).
    pub fn response(&self, pulses: &[Pulse]) -> Channels {
        let mut out = vec![vec![0.0; self.samples]; self.n_out];
        for p in pulses {
            self.add_pulse(p, &mut out);
        }
        out
    }

    fn initial_state(&self, p: &Pulse) -> DVector<f64> {
        assert!(
            (p.duration_s - self.pulse_duration_s).abs() <= 1e-12 * self.pulse_duration_s,
            "engine built for pulses of {} s, got {} s",
            self.pulse_duration_s,
            p.duration_s
        );
        let mut z = DVector::zeros(self.a_on.nrows());
        z[1] = p.peak_n;
        z
    }

    /// Exact propagation from `from_s` to `to_s` (both at or after the
    /// pulse start), switching from the pulse dynamics to free dynamics at
    /// the pulse end.
    fn advance(&self, z: &DVector<f64>, p: &Pulse, from_s: f64, to_s: f64) -> DVector<f64> {
        let t1 = p.end_s();
        let mut z = z.clone();
        let mut t = from_s;
        if t < t1 {
            let until = to_s.min(t1);
            z = balanced_exp(&(&self.a_on * (until - t))) * z;
            t = until;
        }
        if to_s > t {
            z = balanced_exp(&(&self.a_off * (to_s - t))) * z;
        }
        z
    }

    /// One internal step from index `i` to `i + 1`.
    fn step(&self, z: &DVector<f64>, p: &Pulse, i: i64, i_end: i64) -> DVector<f64> {
        if i + 1 < i_end {
            &self.phi_on * z
        } else if i >= i_end {
            &self.phi_off * z
        } else {
            let ti = self.dt_internal_s;
            self.advance(z, p, i as f64 * ti, (i + 1) as f64 * ti)
        }
    }

    fn add_pulse(&self, p: &Pulse, out: &mut Channels) {
        let ti = self.dt_internal_s;
        let d = self.oversampling as i64;
        let l = self.fir_half_length() as i64;
        let k_len = self.taps.len() as i64;
        let n_total = self.samples as i64;
        let i_a = (p.start_s / ti).ceil() as i64; // first grid instant at or after the start
        let i_e = (p.end_s() / ti).ceil() as i64; // first grid instant at or after the end
        let n_first = div_ceil(i_a - l, d).max(0);
        if n_first >= n_total {
            return;
        }
        // First output whose window starts at or after i_e.
        let n_closed = div_ceil(i_e + l, d).max(n_first);
        // Internal samples during the pulse (i_a <= i < i_e), channel-major,
        // and the state at i_e.
        let during = (i_e - i_a).max(0) as usize;
        let mut s = vec![0.0; self.n_out * during];
        let initial = self.initial_state(p);
        let z = match &self.tail {
            FreeTail::Decoupled(dec) if dec.pulse.is_some() => {
                let h = dec.pulse.as_ref().expect("checked");
                let mut z = DVector::zeros(initial.len());
                dec.pulse_response(
                    h,
                    p.peak_n,
                    p.start_s,
                    p.end_s(),
                    i_a,
                    i_e,
                    ti,
                    &mut s,
                    z.as_mut_slice(),
                );
                z
            }
            _ => {
                let mut z = self.advance(&initial, p, p.start_s, i_a as f64 * ti);
                let mut next = z.clone();
                let mut y = DVector::zeros(self.n_out);
                for (k, i) in (i_a..i_e).enumerate() {
                    self.c_out.mul_to(&z, &mut y);
                    for ch in 0..self.n_out {
                        s[ch * during + k] = y[ch];
                    }
                    if i + 1 < i_e {
                        self.phi_on.mul_to(&z, &mut next);
                        std::mem::swap(&mut z, &mut next);
                    } else {
                        z = self.step(&z, p, i, i_e);
                    }
                }
                z
            }
        };
        let (np, nf) = (self.plant_states, self.filter_order);
        let width = np + nf;
        let plant_e = &z.as_slice()[PLANT_AT..PLANT_AT + np];
        // Outputs whose window holds pulse samples and/or reaches the free
        // response from i_e (H_j z_e, j = i_e - window start >= 1).
        for n in n_first..n_closed.min(n_total) {
            let ws = n * d - l;
            let lo = ws.max(i_a);
            let hi = (ws + k_len - 1).min(i_e - 1);
            let j = i_e - ws;
            for ch in 0..self.n_out {
                let mut acc = 0.0;
                if lo <= hi {
                    let taps = &self.taps[(lo - ws) as usize..=(hi - ws) as usize];
                    let row =
                        &s[ch * during + (lo - i_a) as usize..=ch * during + (hi - i_a) as usize];
                    for (t, x) in taps.iter().zip(row) {
                        acc += t * x;
                    }
                }
                if j < k_len {
                    let at = (j as usize * self.n_out + ch) * width;
                    let h = &self.fir_folded[at..at + width];
                    let o = self.filters_at + ch * nf;
                    let filter_e = &z.as_slice()[o..o + nf];
                    for (hv, zv) in h.iter().zip(plant_e.iter().chain(filter_e)) {
                        acc += hv * zv;
                    }
                }
                out[ch][n as usize] += acc;
            }
        }
        if n_closed < n_total {
            let i_closed = n_closed * d - l;
            self.tail.add(
                z.as_slice(),
                (i_closed - i_e) as usize,
                n_closed as usize,
                out,
            );
        }
    }

    /// Brute-force oracle: the whole internal grid stepped one sample at a
    /// time and the FIR evaluated explicitly at every analysis instant.
    pub fn reference_response(&self, pulses: &[Pulse]) -> Channels {
        let ti = self.dt_internal_s;
        let d = self.oversampling as i64;
        let l = self.fir_half_length() as i64;
        let mut out = vec![vec![0.0; self.samples]; self.n_out];
        for p in pulses {
            let i_a = (p.start_s / ti).ceil() as i64;
            let i_e = (p.end_s() / ti).ceil() as i64;
            let i_stop = (self.samples as i64 - 1) * d + l;
            let mut s: Vec<DVector<f64>> = Vec::new();
            let mut z = self.advance(&self.initial_state(p), p, p.start_s, i_a as f64 * ti);
            for i in i_a..=i_stop {
                s.push(&self.c_out * &z);
                z = self.step(&z, p, i, i_e);
            }
            for (n, _) in out[0].clone().iter().enumerate() {
                let centre = n as i64 * d;
                for k in 0..self.taps.len() as i64 {
                    let i = centre - l + k;
                    if i >= i_a {
                        let v = &s[(i - i_a) as usize];
                        for (ch, channel) in out.iter_mut().enumerate() {
                            channel[n] += self.taps[k as usize] * v[ch];
                        }
                    }
                }
            }
        }
        out
    }
}

/// The plant and one analog anti-alias filter per channel as one
/// continuous system `z' = a z + b u`, internal samples `c_out z`. The
/// first `offset` states are left free (zero rows and columns) for a
/// pulse generator; plant states follow, then the filters channel by
/// channel.
struct ChainSystem {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c_out: DMatrix<f64>,
    filters_at: usize,
    filter_order: usize,
    filter_b: DMatrix<f64>,
    filter_c: DMatrix<f64>,
}

impl ChainSystem {
    fn new(plant: &Plant, design: &AnalyzerDesign, offset: usize) -> Self {
        let filt = butterworth(design.analog_order, design.analog_cutoff_hz);
        let nf = filt.a.nrows();
        let n_out = plant.channels();
        let np = plant.states();
        let xs = offset;
        let fs = xs + np;
        let dim = fs + nf * n_out;
        let mut a = DMatrix::zeros(dim, dim);
        a.view_mut((xs, xs), (np, np)).copy_from(&plant.a);
        let mut b = DMatrix::zeros(dim, 1);
        b.view_mut((xs, 0), (np, 1)).copy_from(&plant.b);
        for ch in 0..n_out {
            let o = fs + ch * nf;
            a.view_mut((o, o), (nf, nf)).copy_from(&filt.a);
            // The filter input is channel ch of the plant: c x + d u.
            if plant.c.row(ch).iter().any(|&v| v != 0.0) {
                let coupling = &filt.b * plant.c.row(ch);
                a.view_mut((o, xs), (nf, np)).copy_from(&coupling);
            }
            for r in 0..nf {
                b[(o + r, 0)] = filt.b[(r, 0)] * plant.d[(ch, 0)];
            }
        }
        let mut c_out = DMatrix::zeros(n_out, dim);
        for ch in 0..n_out {
            c_out
                .view_mut((ch, fs + ch * nf), (1, nf))
                .copy_from(&filt.c);
        }
        ChainSystem {
            a,
            b,
            c_out,
            filters_at: fs,
            filter_order: nf,
            filter_b: filt.b,
            filter_c: filt.c,
        }
    }
}

/// Sizes and offsets of the chain's free system (see [`ChainSystem`]).
#[derive(Debug, Clone, Copy)]
struct FreeLayout {
    n_out: usize,
    plant_states: usize,
    filter_order: usize,
    filters_at: usize,
}

/// The FIR output of the free response at the analysis rate, `y_n = G z_n`
/// with `G = H_0` and `z` stepped by `Phi_off` over one analysis interval.
///
/// The free system is lower block triangular: the plant `p' = A_p p` drives
/// every channel's filter, `f_c' = A_f f_c + E_c p`, and nothing else
/// couples. With `X_c` solving the Sylvester equation
/// `A_f X_c - X_c A_p = -E_c`, the states `w_c = f_c - X_c p` are free of
/// the plant (`w_c' = A_f w_c`), so one analysis step costs a plant step,
/// one small filter step per channel (skipped once the filter transients
/// have decayed to exactly zero) and `n_out` short dot products instead of
/// a product with the whole `Phi_off`. When the filter and plant poles are
/// too close for a well-conditioned `X_c` (the check at construction), the
/// whole state is stepped instead.
#[derive(Debug, Clone)]
enum FreeTail {
    Decoupled(Box<Decoupled>),
    Full {
        layout: FreeLayout,
        /// `H_0` as in [`AnalyzerEngine::fir_folded`].
        g: Vec<f64>,
        phi_internal: DMatrix<f64>,
        phi_analysis: DMatrix<f64>,
    },
}

/// Plant and filter transients separated (see [`FreeTail`]); matrices
/// row-major.
#[derive(Debug, Clone)]
struct Decoupled {
    layout: FreeLayout,
    /// `X_c`, `filter_order x plant_states` each, channel after channel.
    x: Vec<f64>,
    phi_p_internal: Vec<f64>,
    phi_f_internal: Vec<f64>,
    phi_p: Vec<f64>,
    phi_f: Vec<f64>,
    /// Output rows on the plant states: `G_c^p + G_c^f X_c`.
    g_p: Vec<f64>,
    /// Output rows on the decoupled filter states: `G_c^f`.
    g_w: Vec<f64>,
    /// The half-sine response in these coordinates (`None` if the pulse
    /// frequency is too close to an undamped pole of the plant).
    pulse: Option<HalfSine>,
}

/// What the pulse enters the chain by: the pulse system's state matrix
/// (column 0, the force, drives the plant and the filters' feedthrough),
/// the analog filter's output row and the pulse duration.
struct PulseInput<'a> {
    a_on: &'a DMatrix<f64>,
    filter_c: &'a [f64],
    duration_s: f64,
}

/// Response of the decoupled chain (plant `p`, filter transients `w_c`,
/// `x = [p; w]`, `x' = A x + b u`) to the unit half-sine
/// `u = sin(omega tau)`, `0 <= tau <= T = pi / omega`, from rest:
/// `x(tau) = alpha sin(omega tau) + beta cos(omega tau) - exp(A tau) beta`
/// with `alpha + i beta = (i omega - A)^-1 b` (the steady sinusoidal
/// response, and the free response that starts it from rest). At the end
/// `x(T) = -beta - exp(A T) beta`. Only matrix exponentials of the plant
/// and of one filter section are needed per hit, at the hit's offsets from
/// the internal grid.
#[derive(Debug, Clone)]
struct HalfSine {
    omega_rad_s: f64,
    a_p: DMatrix<f64>,
    a_f: DMatrix<f64>,
    alpha_p: Vec<f64>,
    beta_p: Vec<f64>,
    /// Channel after channel.
    alpha_w: Vec<f64>,
    beta_w: Vec<f64>,
    end_p: Vec<f64>,
    end_w: Vec<f64>,
    /// Internal sample of channel c: `c_p[c] p + c_w w_c` (`c_p = c_f X_c`).
    c_p: Vec<f64>,
    c_w: Vec<f64>,
}

/// Largest deviation of the closed-form state at the pulse end from the
/// pulse system's exponential accepted (relative, per plant and filter
/// block). Measured 8e-16 on the paper's frame and at most 1e-13 on the
/// models of `tests/response.rs`; a deviation of 1e-10 means a pulse
/// frequency within a few bandwidths of an undamped pole (the steady and
/// free parts then nearly cancel), and the pulse is stepped with the whole
/// system's exponentials instead.
const HALF_SINE_TOLERANCE: f64 = 1e-10;

/// `(i omega - a)^-1 b` as (real part, imaginary part), from the real
/// system `[[-a, -omega], [omega, -a]] [re; im] = [b; 0]`; `None` if it is
/// singular.
fn sine_response(a: &DMatrix<f64>, omega: f64, b: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = a.nrows();
    let mut m = DMatrix::zeros(2 * n, 2 * n);
    m.view_mut((0, 0), (n, n)).copy_from(&(-a));
    m.view_mut((n, n), (n, n)).copy_from(&(-a));
    for i in 0..n {
        m[(i, n + i)] = -omega;
        m[(n + i, i)] = omega;
    }
    let mut rhs = DVector::zeros(2 * n);
    rhs.as_mut_slice()[..n].copy_from_slice(b);
    let sol = m.lu().solve(&rhs)?;
    if sol.iter().any(|v| !v.is_finite()) {
        return None;
    }
    Some((sol.as_slice()[..n].to_vec(), sol.as_slice()[n..].to_vec()))
}

impl HalfSine {
    fn new(
        a_p: DMatrix<f64>,
        a_f: DMatrix<f64>,
        x: &[f64],
        layout: FreeLayout,
        pulse: &PulseInput<'_>,
    ) -> Option<HalfSine> {
        let FreeLayout {
            n_out,
            plant_states: np,
            filter_order: nf,
            filters_at: fs,
        } = layout;
        let omega = pulse.a_on[(0, 1)];
        let b_p: Vec<f64> = (0..np).map(|r| pulse.a_on[(PLANT_AT + r, 0)]).collect();
        let (alpha_p, beta_p) = sine_response(&a_p, omega, &b_p)?;
        let exp_p = balanced_exp(&(&a_p * pulse.duration_s));
        let exp_f = balanced_exp(&(&a_f * pulse.duration_s));
        let end = |beta: &[f64], e: &DMatrix<f64>| -> Vec<f64> {
            let mut y = vec![0.0; beta.len()];
            mat_vec(&row_major(e), beta, &mut y);
            beta.iter().zip(&y).map(|(b, v)| -b - v).collect()
        };
        let end_p = end(&beta_p, &exp_p);
        let (mut alpha_w, mut beta_w, mut end_w) = (Vec::new(), Vec::new(), Vec::new());
        let mut c_p = vec![0.0; n_out * np];
        let mut xb = vec![0.0; nf];
        for c in 0..n_out {
            let x_c = &x[c * nf * np..(c + 1) * nf * np];
            mat_vec(x_c, &b_p, &mut xb);
            let b_w: Vec<f64> = (0..nf)
                .map(|r| pulse.a_on[(fs + c * nf + r, 0)] - xb[r])
                .collect();
            let (al, be) = sine_response(&a_f, omega, &b_w)?;
            end_w.extend(end(&be, &exp_f));
            alpha_w.extend(al);
            beta_w.extend(be);
            for col in 0..np {
                c_p[c * np + col] = (0..nf).map(|r| pulse.filter_c[r] * x_c[r * np + col]).sum();
            }
        }
        // Check the closed form against the whole pulse system's exponential
        // over the pulse: a pulse frequency near a lightly damped pole makes
        // the steady and free parts large and cancelling.
        let reference = balanced_exp(&(pulse.a_on * pulse.duration_s));
        let deviation = |got: &[f64], at: usize| -> f64 {
            let want = reference.view((at, 1), (got.len(), 1));
            let scale = want.norm();
            let diff: f64 = got
                .iter()
                .zip(want.iter())
                .map(|(g, w)| (g - w) * (g - w))
                .sum::<f64>()
                .sqrt();
            if scale > 0.0 { diff / scale } else { diff }
        };
        let mut worst = deviation(&end_p, PLANT_AT);
        for c in 0..n_out {
            let x_c = &x[c * nf * np..(c + 1) * nf * np];
            mat_vec(x_c, &end_p, &mut xb);
            let f: Vec<f64> = (0..nf).map(|r| end_w[c * nf + r] + xb[r]).collect();
            worst = worst.max(deviation(&f, fs + c * nf));
        }
        // NaN fails too.
        let accurate = worst <= HALF_SINE_TOLERANCE;
        if !accurate {
            return None;
        }
        Some(HalfSine {
            omega_rad_s: omega,
            a_p,
            a_f,
            alpha_p,
            beta_p,
            alpha_w,
            beta_w,
            end_p,
            end_w,
            c_p,
            c_w: pulse.filter_c.to_vec(),
        })
    }
}

/// `y = m x` for a row-major `m` of `y.len()` rows.
fn mat_vec(m: &[f64], x: &[f64], y: &mut [f64]) {
    let cols = x.len();
    for (r, yr) in y.iter_mut().enumerate() {
        let row = &m[r * cols..(r + 1) * cols];
        let mut acc = 0.0;
        for (a, b) in row.iter().zip(x) {
            acc += a * b;
        }
        *yr = acc;
    }
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

/// Largest residual `A_f X_c - X_c A_p + E_c` of the Sylvester solutions
/// accepted, relative to `|A_f| |X_c| + |X_c| |A_p| + |E_c|` (Frobenius).
/// The decoupled filter states then obey `w_c' = A_f w_c + R_c p`, and the
/// ignored `R_c p` is an error of that relative size in the filter
/// transients. The LU solution of the Kronecker system is backward stable:
/// 2e-17 on the paper's frames (measured); a residual far above round-off
/// means filter and plant poles too close together, and the whole state is
/// stepped instead.
const SYLVESTER_RESIDUAL_TOLERANCE: f64 = 1e-13;

impl FreeTail {
    /// `g` is `H_0` (as in [`AnalyzerEngine::fir_folded`]).
    fn new(
        a_off: &DMatrix<f64>,
        g: &[f64],
        layout: FreeLayout,
        dt_internal_s: f64,
        dt_s: f64,
        pulse: &PulseInput<'_>,
    ) -> FreeTail {
        match Decoupled::new(a_off, g, layout, dt_internal_s, dt_s, pulse) {
            Some(d) => FreeTail::Decoupled(Box::new(d)),
            None => FreeTail::Full {
                layout,
                g: g.to_vec(),
                phi_internal: balanced_exp(&(a_off * dt_internal_s)),
                phi_analysis: balanced_exp(&(a_off * dt_s)),
            },
        }
    }

    /// Adds the FIR outputs `first..` (to the end of `out`) of the free
    /// response from the full state `z` (at window start of output
    /// `first` minus `internal_steps` internal steps).
    fn add(&self, z: &[f64], internal_steps: usize, first: usize, out: &mut Channels) {
        match self {
            FreeTail::Decoupled(d) => d.add(z, internal_steps, first, out),
            FreeTail::Full {
                layout,
                g,
                phi_internal,
                phi_analysis,
            } => {
                let (np, nf) = (layout.plant_states, layout.filter_order);
                let width = np + nf;
                let mut z = DVector::from_column_slice(z);
                let mut next = z.clone();
                for _ in 0..internal_steps {
                    phi_internal.mul_to(&z, &mut next);
                    std::mem::swap(&mut z, &mut next);
                }
                let samples = out[0].len();
                for n in first..samples {
                    let zs = z.as_slice();
                    for (c, channel) in out.iter_mut().enumerate() {
                        let o = layout.filters_at + c * nf;
                        let row = &g[c * width..(c + 1) * width];
                        let plant = &zs[PLANT_AT..PLANT_AT + np];
                        let mut acc = 0.0;
                        for (h, v) in row.iter().zip(plant.iter().chain(&zs[o..o + nf])) {
                            acc += h * v;
                        }
                        channel[n] += acc;
                    }
                    phi_analysis.mul_to(&z, &mut next);
                    std::mem::swap(&mut z, &mut next);
                }
            }
        }
    }
}

impl Decoupled {
    fn new(
        a_off: &DMatrix<f64>,
        g: &[f64],
        layout: FreeLayout,
        dt_internal_s: f64,
        dt_s: f64,
        pulse: &PulseInput<'_>,
    ) -> Option<Decoupled> {
        let FreeLayout {
            n_out,
            plant_states: np,
            filter_order: nf,
            filters_at: fs,
        } = layout;
        let a_p = a_off.view((PLANT_AT, PLANT_AT), (np, np)).into_owned();
        let a_f = a_off.view((fs, fs), (nf, nf)).into_owned();
        // vec(A_f X - X A_p) = (I (x) A_f - A_p^T (x) I) vec(X), column-major vec.
        let dim = nf * np;
        let mut sylvester = DMatrix::zeros(dim, dim);
        for j in 0..np {
            for r in 0..nf {
                for r2 in 0..nf {
                    sylvester[(j * nf + r, j * nf + r2)] += a_f[(r, r2)];
                }
                for j2 in 0..np {
                    sylvester[(j * nf + r, j2 * nf + r)] -= a_p[(j2, j)];
                }
            }
        }
        let lu = sylvester.lu();
        let mut x = Vec::with_capacity(n_out * dim);
        for c in 0..n_out {
            let o = fs + c * nf;
            // The filters are identical on every channel (one design).
            if a_off.view((o, o), (nf, nf)) != a_f.view((0, 0), (nf, nf)) {
                return None;
            }
            let e = a_off.view((o, PLANT_AT), (nf, np));
            let rhs = DVector::from_iterator(dim, e.iter().map(|v| -v));
            let sol = lu.solve(&rhs)?;
            if sol.iter().any(|v| !v.is_finite()) {
                return None;
            }
            let x_c = DMatrix::from_column_slice(nf, np, sol.as_slice());
            let residual = (&a_f * &x_c - &x_c * &a_p + e).norm();
            let size = (a_f.norm() + a_p.norm()) * x_c.norm() + e.norm();
            // NaN (a non-finite model) fails too.
            let accurate = residual <= SYLVESTER_RESIDUAL_TOLERANCE * size;
            if !accurate {
                return None;
            }
            x.extend(row_major(&x_c));
        }
        let width = np + nf;
        let mut g_p = vec![0.0; n_out * np];
        let mut g_w = vec![0.0; n_out * nf];
        for c in 0..n_out {
            let row = &g[c * width..(c + 1) * width];
            let x_c = &x[c * dim..(c + 1) * dim];
            for col in 0..np {
                let mut acc = row[col];
                for r in 0..nf {
                    acc += row[np + r] * x_c[r * np + col];
                }
                g_p[c * np + col] = acc;
            }
            g_w[c * nf..(c + 1) * nf].copy_from_slice(&row[np..]);
        }
        let pulse = HalfSine::new(a_p.clone(), a_f.clone(), &x, layout, pulse);
        Some(Decoupled {
            pulse,
            layout,
            x,
            phi_p_internal: row_major(&balanced_exp(&(&a_p * dt_internal_s))),
            phi_f_internal: row_major(&balanced_exp(&(&a_f * dt_internal_s))),
            phi_p: row_major(&balanced_exp(&(&a_p * dt_s))),
            phi_f: row_major(&balanced_exp(&(&a_f * dt_s))),
            g_p,
            g_w,
        })
    }

    /// The internal samples during a pulse of peak `peak_n` starting at
    /// `start_s` (at `i_a, i_a + 1, ..` up to `i_e - 1`, channel-major in
    /// `s`, `s.len() / n_out` of them) and the state at `i_e` (as
    /// [`ChainSystem`] orders it, generator states zero).
    #[allow(clippy::too_many_arguments)]
    fn pulse_response(
        &self,
        h: &HalfSine,
        peak_n: f64,
        start_s: f64,
        end_s: f64,
        i_a: i64,
        i_e: i64,
        dt_internal_s: f64,
        s: &mut [f64],
        z_end: &mut [f64],
    ) {
        let FreeLayout {
            n_out,
            plant_states: np,
            filter_order: nf,
            filters_at: fs,
        } = self.layout;
        let during = s.len() / n_out.max(1);
        let exp_vec = |a: &DMatrix<f64>, t: f64, v: &[f64], out: &mut [f64]| {
            let e = balanced_exp(&(a * t));
            for (r, o) in out.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (k, x) in v.iter().enumerate() {
                    acc += e[(r, k)] * x;
                }
                *o = acc;
            }
        };
        if during > 0 {
            // Free part exp(A tau) beta, stepped on the internal grid.
            let tau_a = i_a as f64 * dt_internal_s - start_s;
            let mut free_p = vec![0.0; np];
            let mut free_w = vec![0.0; n_out * nf];
            exp_vec(&h.a_p, tau_a, &h.beta_p, &mut free_p);
            let e_f = balanced_exp(&(&h.a_f * tau_a));
            for (c, fw) in free_w.chunks_mut(nf).enumerate() {
                let beta = &h.beta_w[c * nf..(c + 1) * nf];
                for (r, o) in fw.iter_mut().enumerate() {
                    let mut acc = 0.0;
                    for (k, x) in beta.iter().enumerate() {
                        acc += e_f[(r, k)] * x;
                    }
                    *o = acc;
                }
            }
            let mut next = vec![0.0; np.max(nf)];
            for k in 0..during {
                let tau = (i_a + k as i64) as f64 * dt_internal_s - start_s;
                let (sin, cos) = (h.omega_rad_s * tau).sin_cos();
                for c in 0..n_out {
                    let mut acc = 0.0;
                    for r in 0..np {
                        let p = h.alpha_p[r] * sin + h.beta_p[r] * cos - free_p[r];
                        acc += h.c_p[c * np + r] * p;
                    }
                    for r in 0..nf {
                        let i = c * nf + r;
                        let w = h.alpha_w[i] * sin + h.beta_w[i] * cos - free_w[i];
                        acc += h.c_w[r] * w;
                    }
                    s[c * during + k] = peak_n * acc;
                }
                if k + 1 < during {
                    mat_vec(&self.phi_p_internal, &free_p, &mut next[..np]);
                    free_p.copy_from_slice(&next[..np]);
                    for fw in free_w.chunks_mut(nf) {
                        mat_vec(&self.phi_f_internal, fw, &mut next[..nf]);
                        fw.copy_from_slice(&next[..nf]);
                    }
                }
            }
        }
        // The end state, then the free system up to i_e.
        let tau_e = i_e as f64 * dt_internal_s - end_s;
        z_end.iter_mut().for_each(|v| *v = 0.0);
        let mut p_e = vec![0.0; np];
        exp_vec(&h.a_p, tau_e, &h.end_p, &mut p_e);
        p_e.iter_mut().for_each(|v| *v *= peak_n);
        z_end[PLANT_AT..PLANT_AT + np].copy_from_slice(&p_e);
        let e_f = balanced_exp(&(&h.a_f * tau_e));
        let mut xp = vec![0.0; nf];
        for c in 0..n_out {
            let end = &h.end_w[c * nf..(c + 1) * nf];
            let x_c = &self.x[c * nf * np..(c + 1) * nf * np];
            mat_vec(x_c, &p_e, &mut xp);
            for r in 0..nf {
                let mut acc = 0.0;
                for (k, x) in end.iter().enumerate() {
                    acc += e_f[(r, k)] * x;
                }
                z_end[fs + c * nf + r] = peak_n * acc + xp[r];
            }
        }
    }

    fn add(&self, z: &[f64], internal_steps: usize, first: usize, out: &mut Channels) {
        let FreeLayout {
            n_out,
            plant_states: np,
            filter_order: nf,
            filters_at: fs,
        } = self.layout;
        let mut p = z[PLANT_AT..PLANT_AT + np].to_vec();
        let mut w = vec![0.0; n_out * nf];
        let mut next_p = vec![0.0; np];
        let mut next_w = vec![0.0; nf];
        for c in 0..n_out {
            let x_c = &self.x[c * nf * np..(c + 1) * nf * np];
            mat_vec(x_c, &p, &mut next_w);
            for r in 0..nf {
                w[c * nf + r] = z[fs + c * nf + r] - next_w[r];
            }
        }
        let step_w = |w: &mut [f64], phi: &[f64], next: &mut [f64]| {
            for c in 0..n_out {
                let wc = &mut w[c * nf..(c + 1) * nf];
                mat_vec(phi, wc, next);
                wc.copy_from_slice(next);
            }
        };
        for _ in 0..internal_steps {
            mat_vec(&self.phi_p_internal, &p, &mut next_p);
            std::mem::swap(&mut p, &mut next_p);
            step_w(&mut w, &self.phi_f_internal, &mut next_w);
        }
        let samples = out[0].len();
        if first >= samples {
            return;
        }
        // The filter transients' part of the outputs, while it is not zero
        // (it decays by e^-19 or faster per analysis step, so a few dozen
        // steps), then the plant's part over the whole tail.
        let mut transient: Vec<Vec<f64>> = vec![Vec::new(); n_out];
        while first + transient[0].len() < samples && w.iter().any(|&v| v != 0.0) {
            for (c, t) in transient.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (g, v) in self.g_w[c * nf..(c + 1) * nf].iter().zip(&w[c * nf..]) {
                    acc += g * v;
                }
                t.push(acc);
            }
            step_w(&mut w, &self.phi_f, &mut next_w);
        }
        match np {
            2 => plant_tail::<2>(&self.phi_p, &self.g_p, &p, first, &transient, out),
            4 => plant_tail::<4>(&self.phi_p, &self.g_p, &p, first, &transient, out),
            6 => plant_tail::<6>(&self.phi_p, &self.g_p, &p, first, &transient, out),
            8 => plant_tail::<8>(&self.phi_p, &self.g_p, &p, first, &transient, out),
            _ => {
                for n in first..samples {
                    for (c, channel) in out.iter_mut().enumerate() {
                        let mut acc = 0.0;
                        for (g, v) in self.g_p[c * np..(c + 1) * np].iter().zip(&p) {
                            acc += g * v;
                        }
                        if let Some(t) = transient[c].get(n - first) {
                            acc += t;
                        }
                        channel[n] += acc;
                    }
                    mat_vec(&self.phi_p, &p, &mut next_p);
                    std::mem::swap(&mut p, &mut next_p);
                }
            }
        }
    }
}

/// The plant's part of the free tail for `N` plant states (the sizes of
/// shear frames of 1 to 4 storeys without rig modes), unrolled by the
/// compiler; the same sums in the same order as the general loop.
fn plant_tail<const N: usize>(
    phi: &[f64],
    g_p: &[f64],
    p0: &[f64],
    first: usize,
    transient: &[Vec<f64>],
    out: &mut Channels,
) {
    let mut p = [0.0; N];
    p.copy_from_slice(p0);
    let samples = out[0].len();
    for n in first..samples {
        for (c, channel) in out.iter_mut().enumerate() {
            let g = &g_p[c * N..(c + 1) * N];
            let mut acc = 0.0;
            for k in 0..N {
                acc += g[k] * p[k];
            }
            if let Some(t) = transient[c].get(n - first) {
                acc += t;
            }
            channel[n] += acc;
        }
        let mut next = [0.0; N];
        for (r, v) in next.iter_mut().enumerate() {
            let row = &phi[r * N..(r + 1) * N];
            let mut acc = 0.0;
            for k in 0..N {
                acc += row[k] * p[k];
            }
            *v = acc;
        }
        p = next;
    }
}

/// Ceiling division for a positive divisor.
fn div_ceil(a: i64, b: i64) -> i64 {
    a.div_euclid(b) + i64::from(a.rem_euclid(b) != 0)
}

/// `exp(a)` computed as `D exp(D^-1 a D) D^-1` with a diagonal `D` of powers
/// of two that balances the norms of rows and columns (Parlett and
/// Reinsch): exact scalings that shrink the norm the scaling-and-squaring
/// algorithm works with. The chain's states mix displacements,
/// accelerations and filter states, so its state matrices have entries
/// from 1 to 1e7 and the unbalanced exponentials lose digits: the plant
/// block of the chain's exponential over one analysis step was off by
/// 2e-11 relative (against 40-digit arithmetic). Against the modal
/// superposition through the chain (1024 samples of the paper frame), the
/// records deviate by 5e-14 of their peak with balancing and 2.7e-12
/// without; the brute-force oracle by 3.4e-13 and 2.6e-11 (measured).
fn balanced_exp(a: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.nrows();
    let mut b = a.clone();
    let mut d = vec![1.0f64; n];
    // Each pass scales a row and column by a power of two when that lowers
    // their combined norm by 5 % or more; a few passes converge.
    for _ in 0..64 {
        let mut converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0f64, 0.0f64);
            for j in 0..n {
                if j != i {
                    c += b[(j, i)].abs();
                    r += b[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 || !(c + r).is_finite() {
                continue;
            }
            let total = c + r;
            let mut f = 1.0f64;
            while c < r / 2.0 {
                c *= 2.0;
                r /= 2.0;
                f *= 2.0;
            }
            while c >= r * 2.0 {
                c /= 2.0;
                r *= 2.0;
                f /= 2.0;
            }
            if c + r < 0.95 * total {
                converged = false;
                d[i] *= f;
                for j in 0..n {
                    b[(j, i)] *= f;
                    b[(i, j)] /= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    let mut e = b.exp();
    for j in 0..n {
        for i in 0..n {
            e[(i, j)] *= d[i] / d[j];
        }
    }
    e
}

/// Zero-order-hold engine: force held at its mean over each sample.
#[derive(Debug, Clone)]
pub struct HeldEngine {
    samples: usize,
    dt_s: f64,
    phi: DMatrix<f64>,
    gamma: DVector<f64>,
    /// Output rows of the acceleration channels.
    c: DMatrix<f64>,
    d: DVector<f64>,
    /// Force channel: the held force itself, or `c_force x + d_force u`.
    direct_force: bool,
    c_force: DMatrix<f64>,
    d_force: f64,
}

impl HeldEngine {
    /// `input_dof` is zero-based; `dt_s` the analysis sample interval.
    pub fn new(model: &Model, input_dof: usize, dt_s: f64, samples: usize) -> Self {
        Self::with_plant(&Plant::bare(model, input_dof), dt_s, samples)
    }

    /// The engine for a plant with rig effects ([`Plant::new`]); with the
    /// bare plant this is exactly [`HeldEngine::new`]. The held force drives
    /// the plant; every channel is sampled as `c x[k] + d u[k]`.
    pub fn with_plant(plant: &Plant, dt_s: f64, samples: usize) -> Self {
        let ns = plant.states();
        let n_out = plant.channels();
        // exp([[A, B], [0, 0]] dt) = [[Phi, Gamma], [0, 1]].
        let mut aug = DMatrix::zeros(ns + 1, ns + 1);
        aug.view_mut((0, 0), (ns, ns)).copy_from(&plant.a);
        aug.view_mut((0, ns), (ns, 1)).copy_from(&plant.b);
        let e = (aug * dt_s).exp();
        HeldEngine {
            samples,
            dt_s,
            phi: e.view((0, 0), (ns, ns)).into_owned(),
            gamma: e.view((0, ns), (ns, 1)).column(0).into_owned(),
            c: plant.c.view((1, 0), (n_out - 1, ns)).into_owned(),
            d: plant.d.view((1, 0), (n_out - 1, 1)).column(0).into_owned(),
            direct_force: plant.direct_force,
            c_force: plant.c.view((0, 0), (1, ns)).into_owned(),
            d_force: plant.d[(0, 0)],
        }
    }

    /// The held force (mean of the pulses over each sample) and the exact
    /// response to it: `y[k] = C x[k] + D u[k]`, `x[k+1] = Phi x[k] + Gamma u[k]`.
    pub fn response(&self, pulses: &[Pulse]) -> Channels {
        let u: Vec<f64> = (0..self.samples)
            .map(|k| {
                let (a, b) = (k as f64 * self.dt_s, (k + 1) as f64 * self.dt_s);
                pulses.iter().map(|p| p.integral(a, b)).sum::<f64>() / self.dt_s
            })
            .collect();
        self.response_to_held(&u, 0)
    }

    /// The exact response to a force held at `u[i]` over sample
    /// `first + i` (`[(first + i) dt, (first + i + 1) dt)`), the structure
    /// at rest before sample `first`; samples before 0 (a lead-in) are
    /// simulated but not recorded. `u` must reach the last sample of the
    /// record.
    pub fn response_to_held(&self, u: &[f64], first: i64) -> Channels {
        assert!(first <= 0, "the force must start at or before the record");
        assert!(
            u.len() as i64 + first >= self.samples as i64,
            "the force must cover the record ({} samples from {first})",
            u.len()
        );
        let n = self.c.nrows();
        let mut out = vec![vec![0.0; self.samples]; n + 1];
        let mut x = DVector::zeros(self.phi.nrows());
        for (i, &u) in u.iter().enumerate() {
            let k = first + i as i64;
            if k >= self.samples as i64 {
                break;
            }
            if k >= 0 {
                let k = k as usize;
                out[0][k] = if self.direct_force {
                    u
                } else {
                    (&self.c_force * &x)[(0, 0)] + self.d_force * u
                };
                let y = &self.c * &x + &self.d * u;
                for j in 0..n {
                    out[j + 1][k] = y[j];
                }
            }
            x = &self.phi * x + &self.gamma * u;
        }
        out
    }
}

/// Exact analyzer-chain response to an arbitrary force given on the
/// internal (ADC) grid.
///
/// The force is defined as the piecewise-linear interpolant of its samples
/// `u_i` at `t_i = i dt / oversampling` (first-order hold). Plant and
/// anti-alias filters are one continuous system `z' = A z + B u`; over one
/// internal step with linear `u` the state advances exactly:
/// `z_{i+1} = Phi z_i + Gamma0 u_i + Gamma1 (u_{i+1} - u_i)` with
/// `exp([[A h, B h, 0], [0, 0, 1], [0, 0, 0]]) = [[Phi, Gamma0, Gamma1], ...]`.
/// The internal samples `C_out z_i` then pass the decimation FIR, as for
/// the hammer. The result is the exact sampled response (to rounding) to
/// that piecewise-linear force, on every channel, the force channel
/// included.
///
/// Against an ideal continuous signal `f(t)`, the linear interpolant differs
/// by at most `h^2 max|f''| / 8` (for a sine of frequency f:
/// `(2 pi f h)^2 / 8` of its amplitude, 7.4e-4 at 25 Hz with h = 1/2048 s).
/// In the frequency domain it scales each line by `sinc^2(f h)`
/// (`1 - (pi f h)^2 / 3`: 4.9e-4 low at 25 Hz) and adds images at
/// `f + m / h` weighted by `sinc^2(f h + m)`; what of them passes the
/// analog filter is sampled by the ADC and aliases back onto f (about
/// `(f h)^2 |H_aa(1/h - f)|`, 5e-8 of the line at 7 Hz with the default
/// chain, so the ratio of an acceleration line to the force line differs
/// from the accelerance by that order at most). Both deviations are
/// properties of the force, which the force channel records through the
/// same chain; the tests check recorded sines against this closed form
/// (sum over images) to 1e-10.
#[derive(Debug, Clone)]
pub struct SignalEngine {
    n_out: usize,
    samples: usize,
    oversampling: usize,
    phi: DMatrix<f64>,
    gamma0: DVector<f64>,
    gamma1: DVector<f64>,
    c_out: DMatrix<f64>,
    taps: Vec<f64>,
}

impl SignalEngine {
    /// Engine for `plant` recorded through the analyzer `design` at the
    /// analysis interval `dt_s`, `samples` per record.
    pub fn new(plant: &Plant, dt_s: f64, samples: usize, design: &AnalyzerDesign) -> Self {
        let chain = ChainSystem::new(plant, design, 0);
        let ns = chain.a.nrows();
        let h = dt_s / design.oversampling as f64;
        let mut aug = DMatrix::zeros(ns + 2, ns + 2);
        aug.view_mut((0, 0), (ns, ns)).copy_from(&(&chain.a * h));
        aug.view_mut((0, ns), (ns, 1)).copy_from(&(&chain.b * h));
        aug[(ns, ns + 1)] = 1.0;
        let e = aug.exp();
        SignalEngine {
            n_out: plant.channels(),
            samples,
            oversampling: design.oversampling,
            phi: e.view((0, 0), (ns, ns)).into_owned(),
            gamma0: e.view((0, ns), (ns, 1)).column(0).into_owned(),
            gamma1: e.view((0, ns + 1), (ns, 1)).column(0).into_owned(),
            c_out: chain.c_out,
            taps: kaiser_lowpass(
                design.internal_rate_hz,
                design.passband_hz,
                design.stopband_hz,
                design.stopband_attenuation_db,
            ),
        }
    }

    /// Half-length L of the decimation FIR (taps span internal samples
    /// -L..=L around each analysis instant).
    pub fn fir_half_length(&self) -> usize {
        self.taps.len() / 2
    }

    /// Internal samples per analysis sample.
    pub fn oversampling(&self) -> usize {
        self.oversampling
    }

    /// Internal grid indices the force must cover, from its first index:
    /// `first ..= last_index()`.
    pub fn last_index(&self) -> i64 {
        (self.samples as i64 - 1) * self.oversampling as i64 + self.fir_half_length() as i64
    }

    /// Noise-free channels for the force `u[i]` at internal index
    /// `first + i` (time `(first + i) h`, `h = dt / oversampling`; index 0
    /// is the first sample of the record). The force is zero before
    /// `first` and ramps linearly from 0 to `u[0]` over the preceding step
    /// (so `u[0] = 0` starts it smoothly); the structure is at rest before.
    /// `u` must reach [`SignalEngine::last_index`].
    pub fn response(&self, u: &[f64], first: i64) -> Channels {
        let last = self.last_index();
        assert!(
            first + u.len() as i64 > last,
            "the force must reach internal index {last}"
        );
        let d = self.oversampling as i64;
        let l = self.fir_half_length() as i64;
        // Internal samples s[ch][i - lo] for i in lo..=last; zero before
        // `first`.
        let lo = first.max(-l);
        let count = (last - lo + 1).max(0) as usize;
        let mut s = vec![vec![0.0; count]; self.n_out];
        // Nonzero entries of each output row (one per filter).
        let rows: Vec<Vec<(usize, f64)>> = (0..self.n_out)
            .map(|ch| {
                self.c_out
                    .row(ch)
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(j, v)| (j, *v))
                    .collect()
            })
            .collect();
        let mut z = DVector::zeros(self.phi.nrows());
        let mut next = DVector::zeros(self.phi.nrows());
        let mut u_prev = 0.0;
        for (i, &ui) in u.iter().enumerate() {
            let idx = first + i as i64;
            if idx > last {
                break;
            }
            // Step from idx - 1 to idx.
            next.gemv(1.0, &self.phi, &z, 0.0);
            next.axpy(u_prev, &self.gamma0, 1.0);
            next.axpy(ui - u_prev, &self.gamma1, 1.0);
            std::mem::swap(&mut z, &mut next);
            u_prev = ui;
            if idx >= lo {
                let k = (idx - lo) as usize;
                for (ch, row) in rows.iter().enumerate() {
                    s[ch][k] = row.iter().map(|&(j, c)| c * z[j]).sum();
                }
            }
        }
        let mut out = vec![vec![0.0; self.samples]; self.n_out];
        for n in 0..self.samples as i64 {
            // Window n d - l ..= n d + l, clipped below at lo.
            let start = n * d - l;
            let skip = (lo - start).max(0) as usize;
            if skip >= self.taps.len() {
                continue; // the window ends before the force starts
            }
            let from = (start + skip as i64 - lo) as usize;
            let taps = &self.taps[skip..];
            for (ch, channel) in out.iter_mut().enumerate() {
                let window = &s[ch][from..from + taps.len()];
                channel[n as usize] = taps.iter().zip(window).map(|(t, v)| t * v).sum();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analyzer::AnalyzerSettings;

    /// The paper's case-1 frame (as `scenarios/paper-case1.toml`).
    fn paper_case1() -> Model {
        let mass = DMatrix::from_row_slice(2, 2, &[0.2913, 0.0153, 0.0153, 0.3387]);
        let stiffness = DMatrix::from_row_slice(2, 2, &[630.44, -425.83, -425.83, 439.01]);
        let damping = &mass * 0.1755 + &stiffness * 3.2283e-5;
        Model::new(mass, stiffness, damping).unwrap()
    }

    fn worst_relative(a: &Channels, b: &Channels) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| {
                let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                x.iter()
                    .zip(y)
                    .fold(0.0f64, |m, (u, v)| m.max((u - v).abs() / scale))
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn fallback_paths_give_the_same_records() {
        let design = AnalyzerSettings::default().design(64.0).unwrap();
        let dt_s = 1.0 / 64.0;
        let engine = AnalyzerEngine::new(&paper_case1(), 0, 0.003, dt_s, 512, &design);
        let FreeTail::Decoupled(dec) = &engine.tail else {
            panic!("the paper frame decouples");
        };
        assert!(dec.pulse.is_some(), "the half-sine has a closed form");
        // The pulse stepped with the whole chain's exponentials, then the
        // decoupled tail.
        let mut stepped = engine.clone();
        if let FreeTail::Decoupled(d) = &mut stepped.tail {
            d.pulse = None;
        }
        // Everything with the whole state.
        let mut full = stepped.clone();
        let width = engine.plant_states + engine.filter_order;
        full.tail = FreeTail::Full {
            layout: dec.layout,
            g: engine.fir_folded[..engine.n_out * width].to_vec(),
            phi_internal: engine.phi_off.clone(),
            phi_analysis: balanced_exp(&(&engine.a_off * dt_s)),
        };
        for pulses in [
            vec![Pulse {
                start_s: 0.50731,
                duration_s: 0.003,
                peak_n: 12.5,
            }],
            vec![
                Pulse {
                    start_s: 0.6003,
                    duration_s: 0.003,
                    peak_n: 9.0,
                },
                Pulse {
                    start_s: 0.6063,
                    duration_s: 0.003,
                    peak_n: 4.0,
                },
            ],
        ] {
            let fast = engine.response(&pulses);
            for other in [&stepped, &full] {
                let worst = worst_relative(&other.response(&pulses), &fast);
                // All three are exact to rounding. Measured over 512 samples,
                // relative to each channel's peak: 2.8e-15 with the pulse
                // stepped, 4.8e-13 with the whole state stepped at the
                // analysis rate (its 18-state exponential is the least
                // accurate); 2e-12 leaves a factor of 4.
                assert!(worst < 2e-12, "worst relative deviation {worst:e}");
            }
        }
    }
}
