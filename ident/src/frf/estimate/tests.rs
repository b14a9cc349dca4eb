use super::*;
use crate::linalg;
use crate::record::Channel;
use crate::statespace::StateSpace;
use crate::testutil::normal;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

// ---------------------------------------------------------------- helpers

/// Naive DFT `X_k = sum_n x_n exp(-i 2 pi k n / N)`, the oracle for the FFT path.
/// The phase is reduced modulo `N` in integers so that it stays accurate.
fn naive_dft(x: &[f64]) -> Vec<C64> {
    let n = x.len();
    (0..n)
        .map(|k| {
            x.iter()
                .enumerate()
                .map(|(t, &v)| C64::from_polar(v, -2.0 * PI * ((k * t) % n) as f64 / n as f64))
                .sum()
        })
        .collect()
}

/// Causal FIR filter from rest.
fn fir(x: &[f64], taps: &[f64]) -> Vec<f64> {
    (0..x.len())
        .map(|n| {
            taps.iter()
                .enumerate()
                .filter(|(j, _)| *j <= n)
                .map(|(j, &h)| h * x[n - j])
                .sum()
        })
        .collect()
}

/// Frequency response of a FIR filter at `f` Hz.
fn fir_frf(taps: &[f64], f: f64, dt: f64) -> C64 {
    taps.iter()
        .enumerate()
        .map(|(j, &h)| C64::from_polar(h, -2.0 * PI * f * dt * j as f64))
        .sum()
}

fn white(rng: &mut ChaCha8Rng, n: usize, sigma: f64) -> Vec<f64> {
    (0..n).map(|_| sigma * normal(rng)).collect()
}

fn record(inputs: &[Vec<f64>], outputs: &[Vec<f64>]) -> Record {
    let n = inputs[0].len();
    Record::new(
        DMatrix::from_fn(inputs.len(), n, |c, t| inputs[c][t]),
        DMatrix::from_fn(outputs.len(), n, |c, t| outputs[c][t]),
    )
}

fn add_noise(rng: &mut ChaCha8Rng, x: &[f64], sigma: f64) -> Vec<f64> {
    x.iter().map(|v| v + sigma * normal(rng)).collect()
}

/// Largest entry-wise difference of two sequences of complex matrices, relative to the
/// largest entry of `want`.
fn max_rel(got: &[DMatrix<C64>], want: &[DMatrix<C64>]) -> f64 {
    assert_eq!(got.len(), want.len());
    let scale = want
        .iter()
        .flat_map(|w| w.iter().map(|z| z.norm()))
        .fold(0.0, f64::max);
    got.iter()
        .zip(want)
        .flat_map(|(g, w)| g.iter().zip(w.iter()).map(|(a, b)| (a - b).norm()))
        .fold(0.0, f64::max)
        / scale
}

/// Per line: `Gxx`, `Gyx`, `Gyy` (diagonal) and the full response cross-spectra.
type OracleSpectra = (
    Vec<DMatrix<C64>>,
    Vec<DMatrix<C64>>,
    Vec<DVector<f64>>,
    Vec<DMatrix<C64>>,
);

/// Oracle spectra: naive DFTs of the given windowed blocks, summed and scaled exactly
/// as the module docs say. `blocks[b][c]` is channel `c` (inputs first) of block `b`,
/// already windowed and zero-padded to the FFT length.
fn oracle_spectra(blocks: &[Vec<Vec<f64>>], r: usize, base_scale: f64) -> OracleSpectra {
    let nfft = blocks[0][0].len();
    let channels = blocks[0].len();
    let m = channels - r;
    let lines = nfft / 2 + 1;
    let mut gxx = vec![DMatrix::zeros(r, r); lines];
    let mut gyx = vec![DMatrix::zeros(m, r); lines];
    let mut gyy = vec![DVector::zeros(m); lines];
    let mut gyy_full = vec![DMatrix::zeros(m, m); lines];
    for block in blocks {
        let dft: Vec<Vec<C64>> = block.iter().map(|x| naive_dft(x)).collect();
        for k in 0..lines {
            for a in 0..r {
                for b in 0..r {
                    gxx[k][(a, b)] += dft[a][k] * dft[b][k].conj();
                }
            }
            for i in 0..m {
                for j in 0..r {
                    gyx[k][(i, j)] += dft[r + i][k] * dft[j][k].conj();
                }
                gyy[k][i] += dft[r + i][k].norm_sqr();
                for l in 0..m {
                    gyy_full[k][(i, l)] += dft[r + i][k] * dft[r + l][k].conj();
                }
            }
        }
    }
    let n = blocks.len() as f64;
    for k in 0..lines {
        let one_sided = if k == 0 || 2 * k == nfft { 1.0 } else { 2.0 };
        let s = one_sided * base_scale / n;
        gxx[k] *= C64::new(s, 0.0);
        gyx[k] *= C64::new(s, 0.0);
        gyy[k] *= s;
        gyy_full[k] *= C64::new(s, 0.0);
    }
    (gxx, gyx, gyy, gyy_full)
}

fn to_complex(v: &[DVector<f64>]) -> Vec<DMatrix<C64>> {
    v.iter()
        .map(|d| DMatrix::from_fn(d.len(), 1, |i, _| C64::new(d[i], 0.0)))
        .collect()
}

// ---------------------------------------------------------------- spectra vs oracle

/// Welch path (Hann, 25 % overlap, several records of different lengths, 2 references,
/// 2 and 3 responses) against naive DFTs of independently windowed segments.
#[test]
fn welch_spectra_match_naive_dft() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let dt = 0.01;
    let len = 16;
    for m in [2, 3] {
        let records: Vec<Record> = [70, 45]
            .iter()
            .map(|&n| {
                let x: Vec<Vec<f64>> = (0..2).map(|_| white(&mut rng, n, 1.0)).collect();
                let y: Vec<Vec<f64>> = (0..m).map(|_| white(&mut rng, n, 2.0)).collect();
                record(&x, &y)
            })
            .collect();
        let welch = WelchAveraging {
            segment_len: len,
            overlap: 0.25,
            window: SegmentWindow::Hann,
        };
        let est = FrfParams::welch(len)
            .averaging(Averaging::Welch(welch))
            .estimate(&records, dt)
            .unwrap();
        // Oracle: step 16 - round(4) = 12; (70-16)/12+1 = 5 and (45-16)/12+1 = 3 segments.
        let hann: Vec<f64> = (0..len)
            .map(|n| 0.5 - 0.5 * (2.0 * PI * n as f64 / len as f64).cos())
            .collect();
        let mut blocks = Vec::new();
        for rec in &records {
            let mut start = 0;
            while start + len <= rec.len() {
                let chans: Vec<Vec<f64>> = (0..2 + m)
                    .map(|c| {
                        (0..len)
                            .map(|t| {
                                let v = if c < 2 {
                                    rec.inputs[(c, start + t)]
                                } else {
                                    rec.outputs[(c - 2, start + t)]
                                };
                                v * hann[t]
                            })
                            .collect()
                    })
                    .collect();
                blocks.push(chans);
                start += 12;
            }
        }
        assert_eq!(blocks.len(), 8);
        assert_eq!(est.spectra.averages, 8);
        assert_eq!(est.frf.averages, Some(8));
        let power: f64 = hann.iter().map(|w| w * w).sum();
        let (gxx, gyx, gyy, gyy_full) = oracle_spectra(&blocks, 2, dt / power);
        // O(N) sums of O(1) terms by two DFT algorithms: round-off ~ 1e-15 relative.
        let tol = 1e-12;
        assert!(max_rel(&est.spectra.gxx, &gxx) < tol);
        assert!(max_rel(&est.spectra.gyx, &gyx) < tol);
        assert!(max_rel(&to_complex(&est.spectra.gyy), &to_complex(&gyy)) < tol);
        match (m, &est.spectra.output_cross) {
            (2, Some(full)) => assert!(max_rel(full, &gyy_full) < tol),
            (3, None) => {}
            _ => panic!("output cross-spectra kept exactly when outputs == references > 1"),
        }
        for (k, &f) in est.frf.frequency_hz.iter().enumerate() {
            assert_eq!(f, k as f64 / (len as f64 * dt));
        }
        assert_eq!(est.frf.lines(), len / 2 + 1);
        assert_eq!(est.windows.segment_step, Some(12));
        est.frf.validate().unwrap();
    }
}

/// Hit path (zero padding, force window, exponential window, band, a reference that
/// is zero in one hit) against naive DFTs of independently windowed records.
#[test]
fn hit_spectra_match_naive_dft() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let dt = 0.002;
    let nfft = 40;
    let lengths = [20, 27, 31];
    let records: Vec<Record> = lengths
        .iter()
        .enumerate()
        .map(|(h, &n)| {
            let x: Vec<Vec<f64>> = (0..2)
                .map(|c| {
                    if h == 1 && c == 1 {
                        vec![0.0; n]
                    } else {
                        white(&mut rng, n, 1.0)
                    }
                })
                .collect();
            let y: Vec<Vec<f64>> = (0..2).map(|_| white(&mut rng, n, 1.0)).collect();
            record(&x, &y)
        })
        .collect();
    let fw = ForceWindow {
        before_peak_s: 2.0 * dt,
        after_peak_s: 3.0 * dt,
        taper_s: 2.5 * dt,
    };
    let end = 0.1;
    let params = FrfParams::hits()
        .averaging(Averaging::Hits(HitAveraging {
            block_len: Some(nfft),
            force_window: Some(fw),
            exponential_window: Some(ExponentialWindow::EndAmplitude(end)),
        }))
        .band_hz(0.1 / dt, 0.4 / dt);
    let est = params.estimate(&records, dt).unwrap();
    // Oracle windows: the exponential as end^(n / (N_max - 1)), N_max = 31.
    let mut blocks = Vec::new();
    let mut peaks = Vec::new();
    for rec in &records {
        let n = rec.len();
        let expw: Vec<f64> = (0..n).map(|t| end.powf(t as f64 / 30.0)).collect();
        let mut rec_peaks = Vec::new();
        let chans: Vec<Vec<f64>> = (0..4)
            .map(|c| {
                let raw: Vec<f64> = (0..n)
                    .map(|t| {
                        if c < 2 {
                            rec.inputs[(c, t)]
                        } else {
                            rec.outputs[(c - 2, t)]
                        }
                    })
                    .collect();
                let mut w = expw.clone();
                if c < 2 {
                    let peak = (0..n)
                        .filter(|&t| raw[t] != 0.0)
                        .max_by(|&a, &b| raw[a].abs().total_cmp(&raw[b].abs()));
                    if let Some(p) = peak {
                        for (t, wt) in w.iter_mut().enumerate() {
                            *wt *= fw.weight((t as f64 - p as f64) * dt);
                        }
                    }
                    rec_peaks.push(peak);
                }
                let mut v: Vec<f64> = raw.iter().zip(&w).map(|(a, b)| a * b).collect();
                v.resize(nfft, 0.0);
                v
            })
            .collect();
        peaks.push(rec_peaks);
        blocks.push(chans);
    }
    assert_eq!(est.windows.force_peaks, peaks);
    assert_eq!(peaks[1][1], None);
    let tau = est.windows.exponential_tau_s.unwrap();
    // tau is defined by the end amplitude at sample N_max - 1: a closed form.
    assert!(((-(30.0 * dt) / tau).exp() - end).abs() < 1e-15);
    let (gxx, gyx, gyy, _) = oracle_spectra(&blocks, 2, dt * dt);
    // Band 50..200 Hz at 12.5 Hz spacing: bins 4..=16 of 0..=20.
    let (k0, k1) = (4, 16);
    assert_eq!(est.frf.frequency_hz.first(), Some(&50.0));
    assert_eq!(est.frf.lines(), k1 - k0 + 1);
    // As above: round-off of short DFT sums.
    let tol = 1e-12;
    assert!(max_rel(&est.spectra.gxx, &gxx[k0..=k1]) < tol);
    assert!(max_rel(&est.spectra.gyx, &gyx[k0..=k1]) < tol);
    assert!(max_rel(&to_complex(&est.spectra.gyy), &to_complex(&gyy[k0..=k1])) < tol);
    assert_eq!(est.spectra.scaling, SpectrumScaling::EnergyDensityPerHit);
    assert_eq!(est.frf.averages, Some(3));
    est.frf.validate().unwrap();
}

// ---------------------------------------------------------------- windows

#[test]
fn windows_follow_their_closed_forms() {
    // Periodic Hann: zero at the start, one in the middle, and two copies half a
    // segment apart sum to one (which is why 50 % overlap weights samples evenly).
    let len = 64;
    let w = |n: usize| SegmentWindow::Hann.weight(n % len, len);
    assert_eq!(w(0), 0.0);
    assert!((w(len / 2) - 1.0).abs() < 1e-15);
    for n in 0..len {
        // sin^2 + cos^2 in floating point: an ulp or two.
        assert!((w(n) + w(n + len / 2) - 1.0).abs() < 1e-15);
    }
    let fw = ForceWindow {
        before_peak_s: 0.01,
        after_peak_s: 0.02,
        taper_s: 0.004,
    };
    assert_eq!(fw.weight(0.0), 1.0);
    assert_eq!(fw.weight(-0.01), 1.0);
    assert_eq!(fw.weight(0.02), 1.0);
    // Half-way down each taper the half-cosine is 1/2; a few ulps from the sums.
    assert!((fw.weight(0.022) - 0.5).abs() < 1e-12);
    assert!((fw.weight(-0.012) - 0.5).abs() < 1e-12);
    assert_eq!(fw.weight(0.024), 0.0);
    assert_eq!(fw.weight(-0.0141), 0.0);
    assert_eq!(fw.weight(1.0), 0.0);
    // Continuity at the edges of the flat part.
    assert!((fw.weight(0.02 + 1e-9) - 1.0).abs() < 1e-9);
    let sharp = ForceWindow { taper_s: 0.0, ..fw };
    assert_eq!(sharp.weight(0.020_000_1), 0.0);
    // End amplitude: exp(-(N-1) dt / tau) = a.
    let tau = ExponentialWindow::EndAmplitude(0.05).tau_s(1001, 0.01);
    assert!(((-10.0 / tau).exp() - 0.05).abs() < 1e-15);
    assert_eq!(ExponentialWindow::TimeConstant(3.0).tau_s(10, 1.0), 3.0);
    let wa = WelchAveraging::new(256);
    assert_eq!(wa.step(), 128);
    assert_eq!(wa.segments(255), 0);
    assert_eq!(wa.segments(256), 1);
    assert_eq!(wa.segments(256 + 127), 1);
    assert_eq!(wa.segments(256 + 128), 2);
}

// ---------------------------------------------------------------- exact systems

/// Hits whose complete responses fit in the record: `Y_k = H X_k` holds exactly at every
/// line, so H1, H2 and Hv all equal the FIR's FRF and the coherences are 1, for one and
/// for two references.
#[test]
fn contained_transients_give_the_exact_frf() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let dt = 1.0 / 128.0;
    let n = 32;
    for r in [1, 2] {
        let m = 2;
        let taps: Vec<Vec<Vec<f64>>> = (0..m)
            .map(|_| (0..r).map(|_| white(&mut rng, 5, 1.0)).collect())
            .collect();
        let records: Vec<Record> = (0..3)
            .map(|_| {
                let x: Vec<Vec<f64>> = (0..r)
                    .map(|_| {
                        let mut v = white(&mut rng, 20, 1.0);
                        v.resize(n, 0.0);
                        v
                    })
                    .collect();
                let y: Vec<Vec<f64>> = (0..m)
                    .map(|i| {
                        let mut acc = vec![0.0; n];
                        for j in 0..r {
                            for (a, b) in acc.iter_mut().zip(fir(&x[j], &taps[i][j])) {
                                *a += b;
                            }
                        }
                        acc
                    })
                    .collect();
                record(&x, &y)
            })
            .collect();
        for estimator in [Estimator::H1, Estimator::H2, Estimator::Hv] {
            let est = FrfParams::hits()
                .estimator(estimator)
                .estimate(&records, dt)
                .unwrap();
            let want: Vec<DMatrix<C64>> = est
                .frf
                .frequency_hz
                .iter()
                .map(|&f| DMatrix::from_fn(m, r, |i, j| fir_frf(&taps[i][j], f, dt)))
                .collect();
            let err = max_rel(&est.frf.values, &want);
            // Exact relation; round-off of 32-point FFTs and of a 2x2 or 3x3
            // eigenproblem: 1e-15..1e-13.
            assert!(err < 1e-11, "r = {r}, {estimator}: error {err:e}");
            for (k, c) in est.multiple_coherence.iter().enumerate() {
                for &g in c.iter() {
                    // 1 - g is round-off of |Gyx|^2 against Gxx Gyy.
                    assert!(g > 1.0 - 1e-12, "line {k}: multiple coherence {g}");
                }
            }
            if r == 1 {
                for c in est.frf.coherence.as_ref().unwrap() {
                    assert!(c.iter().all(|&g| g > 1.0 - 1e-12));
                }
            }
        }
    }
}

/// Discrete 2-DOF frame (the paper's M, K and Rayleigh damping, ZOH at 64 Hz), force at
/// floor 1, accelerations at both floors.
fn frame() -> (StateSpace, DMatrix<f64>) {
    let (ac, bc, c, d) = testkit::paper_case1().continuous(0);
    let dt = 1.0 / 64.0;
    let (ad, bd) = testkit::zoh(&ac, &bc, dt);
    (StateSpace::new(ad, bd, c, d, dt), ac)
}

/// `D + C (z I - rho A)^-1 rho B` at `z = exp(i 2 pi f dt)`: the FRF of the discrete
/// system, and with `rho = exp(-dt / tau)` the FRF of its exponentially windowed records.
fn discrete_frf(sys: &StateSpace, f: f64, rho: f64) -> DMatrix<C64> {
    let n = sys.order();
    let z = C64::from_polar(1.0, 2.0 * PI * f * sys.dt_s);
    let a = sys.a.map(|v| C64::new(rho * v, 0.0));
    let b = sys.b.map(|v| C64::new(rho * v, 0.0));
    let zi = DMatrix::<C64>::identity(n, n) * z - a;
    let x = zi.lu().solve(&b).unwrap();
    sys.c.map(|v| C64::new(v, 0.0)) * x + sys.d.map(|v| C64::new(v, 0.0))
}

/// Hammer hits (different pulses and trigger delays) on the frame, records long enough
/// for the response to decay below 1e-10: the hit-averaged H1 reproduces the discrete
/// FRF at every line.
fn frame_hits(sys: &StateSpace, n: usize) -> Vec<Record> {
    [
        (5, 1.0, 0.3),
        (12, 0.7, 0.25),
        (20, 1.3, 0.35),
        (8, 0.9, 0.2),
    ]
    .iter()
    .map(|&(start, amp, side)| {
        let mut u = DMatrix::zeros(1, n);
        u[(0, start)] = amp * side;
        u[(0, start + 1)] = amp;
        u[(0, start + 2)] = amp * side;
        let y = sys.simulate(&u);
        Record::new(u, y)
    })
    .collect()
}

#[test]
fn hammer_hits_on_a_two_dof_frame_reproduce_its_frf() {
    let (sys, _) = frame();
    // 256 s: the slowest decay (mode 1, xi w ~ 0.093 1/s) leaves exp(-23.8) ~ 5e-11 of
    // the response at the end of the record.
    let records = frame_hits(&sys, 16384);
    for estimator in [Estimator::H1, Estimator::H2, Estimator::Hv] {
        let est = FrfParams::hits()
            .estimator(estimator)
            .band_hz(0.1, 30.0)
            .estimate(&records, sys.dt_s)
            .unwrap();
        let want: Vec<DMatrix<C64>> = est
            .frf
            .frequency_hz
            .iter()
            .map(|&f| discrete_frf(&sys, f, 1.0))
            .collect();
        let err = max_rel(&est.frf.values, &want);
        // Truncation leaves ~5e-11 of the peak response; the force spectrum is flat
        // within a factor 2, so the FRF error relative to its peak is of that order
        // (measured 1.6e-11).
        assert!(err < 2e-10, "{estimator}: relative error {err:e}");
        assert_eq!(est.frf.quantity, FrfQuantity::Accelerance);
        assert_eq!(est.frf.averages, Some(4));
        est.frf.validate().unwrap();
        println!("2-DOF hits, {estimator}: max error / max |H| = {err:.2e}");
    }
}

/// Fits `H(z) = N_i(z^-1) / (1 + a_1 z^-1 + ... + a_4 z^-4)` (common denominator) to FRF
/// lines by linear least squares (Levy) and returns the continuous poles
/// `ln(z) / dt` with positive imaginary part, ascending.
fn levy_poles(freqs: &[f64], values: &[DMatrix<C64>], dt: f64) -> Vec<C64> {
    let order = 4;
    let m = values[0].nrows();
    let cols = order + m * (order + 1);
    let rows = 2 * m * freqs.len();
    let mut a = DMatrix::<f64>::zeros(rows, cols);
    let mut b = DMatrix::<f64>::zeros(rows, 1);
    let mut row = 0;
    for (&f, h) in freqs.iter().zip(values) {
        let zinv = C64::from_polar(1.0, -2.0 * PI * f * dt);
        for i in 0..m {
            let hi = h[(i, 0)];
            let mut eq = vec![C64::new(0.0, 0.0); cols];
            for j in 1..=order {
                eq[j - 1] = -hi * zinv.powi(j as i32);
            }
            for j in 0..=order {
                eq[order + i * (order + 1) + j] = zinv.powi(j as i32);
            }
            for (c, e) in eq.iter().enumerate() {
                a[(row, c)] = e.re;
                a[(row + 1, c)] = e.im;
            }
            b[(row, 0)] = hi.re;
            b[(row + 1, 0)] = hi.im;
            row += 2;
        }
    }
    let coef = a.svd(true, true).solve(&b, 1e-14).unwrap();
    let mut companion = DMatrix::zeros(order, order);
    for j in 0..order {
        companion[(0, j)] = -coef[(j, 0)];
    }
    for j in 1..order {
        companion[(j, j - 1)] = 1.0;
    }
    let mut poles: Vec<C64> = linalg::eigenvalues(&companion)
        .unwrap()
        .iter()
        .filter(|z| z.im > 0.0)
        .map(|z| z.ln() / dt)
        .collect();
    poles.sort_by(|p, q| p.im.total_cmp(&q.im));
    poles
}

/// Exponential window on the frame's hits: the windowed FRF is exactly the FRF of the
/// system with every discrete pole scaled by `exp(-dt/tau)` (continuous poles shifted
/// by `-1/tau`); a rational fit of the estimated FRF finds the shifted poles, and
/// `correct_exponential_window` recovers the true frequencies and damping ratios.
#[test]
fn exponential_window_shift_is_exact_and_its_correction_recovers_damping() {
    let (sys, ac) = frame();
    let dt = sys.dt_s;
    let n = 8192;
    let records = frame_hits(&sys, n);
    // tau = 10 s: ends at exp(-12.8) ~ 3e-6 times the natural decay exp(-11.9) ~ 7e-6.
    let tau = 10.0;
    let est = FrfParams::hits()
        .averaging(Averaging::Hits(HitAveraging {
            exponential_window: Some(ExponentialWindow::TimeConstant(tau)),
            ..HitAveraging::default()
        }))
        .band_hz(0.5, 25.0)
        .estimate(&records, dt)
        .unwrap();
    assert_eq!(est.windows.exponential_tau_s, Some(tau));
    let rho = (-dt / tau).exp();
    let want: Vec<DMatrix<C64>> = est
        .frf
        .frequency_hz
        .iter()
        .map(|&f| discrete_frf(&sys, f, rho))
        .collect();
    let err = max_rel(&est.frf.values, &want);
    // Truncated tail ~ 2e-11 of the peak response (see above).
    assert!(err < 2e-10, "windowed FRF error {err:e}");
    println!("2-DOF hits, exponential window: max error / max |H_w| = {err:.2e}");

    // True continuous poles of the frame.
    let mut truth: Vec<C64> = linalg::eigenvalues(&ac)
        .unwrap()
        .iter()
        .copied()
        .filter(|p| p.im > 0.0)
        .collect();
    truth.sort_by(|p, q| p.im.total_cmp(&q.im));
    let modal = |p: C64| (p.norm() / (2.0 * PI), -p.re / p.norm());
    let fitted = levy_poles(&est.frf.frequency_hz, &est.frf.values, dt);
    assert_eq!(fitted.len(), 2);
    for (j, (&p, &lw)) in truth.iter().zip(&fitted).enumerate() {
        // The closed form: the windowed pole is the true pole minus 1/tau.
        let shift_err = (lw - (p - 1.0 / tau)).norm() / p.norm();
        // Levy fit of data exact to ~2e-11 (truncation): measured 1.5e-13 and 5e-15;
        // 1e-10 leaves room for the conditioning of the 14-column Vandermonde-like
        // system on other platforms.
        assert!(
            shift_err < 1e-10,
            "mode {j}: pole shift error {shift_err:e}"
        );
        let (f, xi) = modal(p);
        let (fw, xiw) = modal(lw);
        let (fc, xic) = correct_exponential_window(fw, xiw, tau).unwrap();
        let (fc2, xic2) = est.correct_exponential_window(fw, xiw).unwrap();
        assert_eq!((fc, xic), (fc2, xic2));
        println!(
            "mode {j}: f {f:.6} Hz, xi {xi:.6}; windowed xi {xiw:.6}; corrected xi {xic:.6} \
             (relative error {:.1e}); pole shift error {shift_err:.1e}",
            (xic - xi).abs() / xi
        );
        // The window adds 1/(tau w) ~ 0.6 % and 0.2 % to xi ~ 0.5 % and 0.25 %: without
        // the correction the error would be 35..110 %.
        assert!((xiw - xi) / xi > 0.2);
        // A pole error of 1e-10 relative gives a xi error of ~ 1e-10 / xi ~ 4e-8
        // relative (measured 6e-12 and 2e-12).
        assert!((xic - xi).abs() / xi < 1e-7, "mode {j}: xi {xic} vs {xi}");
        assert!((fc - f).abs() / f < 1e-10, "mode {j}: f {fc} vs {f}");
    }
}

#[test]
fn exponential_correction_is_exact_in_the_pole() {
    let cases = [
        (2.7, 0.005, 10.0),
        (9.0, 0.0025, 0.5),
        (1.0, 0.02, 0.05),
        (50.0, 0.3, 0.01),
        (0.5, -0.01, 100.0),
    ];
    let mut worst_approx: f64 = 0.0;
    for &(f, xi, tau) in &cases {
        let w = 2.0 * PI * f;
        let pole = C64::new(-xi * w, w * (1.0 - xi * xi).sqrt());
        let lw = pole - 1.0 / tau;
        let (fw, xiw) = (lw.norm() / (2.0 * PI), -lw.re / lw.norm());
        let (fc, xic) = correct_exponential_window(fw, xiw, tau).unwrap();
        // A handful of floating-point operations on O(1) quantities; xi is compared
        // relative to the window's contribution, which dominates the arithmetic.
        assert!((fc - f).abs() <= 1e-12 * f, "{f} {xi} {tau}: f {fc}");
        assert!(
            (xic - xi).abs() <= 1e-12 * (xi.abs() + 1.0 / (tau * w)),
            "{f} {xi} {tau}: xi {xic}"
        );
        // The small-damping approximation, for comparison.
        let approx = xiw - 1.0 / (tau * 2.0 * PI * fw);
        worst_approx = worst_approx.max((approx - xi).abs());
    }
    // A heavy window on a 1 Hz mode (tau w ~ 0.3) breaks the approximation: its error
    // on xi is 0.036 there (on xi = 0.02), against 1e-12 for the exact correction.
    assert!(worst_approx > 0.02, "approximation error {worst_approx}");
    for (f, xi, tau) in [
        (0.0, 0.01, 1.0),
        (f64::NAN, 0.01, 1.0),
        (1.0, 1.0, 1.0),
        (1.0, f64::NAN, 1.0),
        (1.0, 0.01, 0.0),
        (1.0, 0.01, f64::INFINITY),
    ] {
        assert!(matches!(
            correct_exponential_window(f, xi, tau),
            Err(FrfEstimateError::InvalidMode { .. })
        ));
    }
}

// ---------------------------------------------------------------- noise and bias

const TAPS: [f64; 4] = [0.8, 0.6, -0.4, 0.2];

/// One long record of white force through the FIR `TAPS`, with white noise of the given
/// standard deviations added to the measured force and response.
fn noisy_fir_record(rng: &mut ChaCha8Rng, n: usize, input_noise: f64, output_noise: f64) -> Record {
    let x = white(rng, n, 1.0);
    let y = fir(&x, &TAPS);
    let xm = add_noise(rng, &x, input_noise);
    let ym = add_noise(rng, &y, output_noise);
    record(&[xm], &[ym])
}

struct Ratios {
    /// Mean over lines of `H1 / H`, `H2 / H`, `Hv / H`.
    h1: C64,
    h2: C64,
    hv: C64,
    /// Mean over lines of `coherence - closed form`.
    coherence_bias: f64,
    /// Largest |coherence - closed form| over lines.
    coherence_max: f64,
}

/// Welch estimate of `TAPS` with noise; returns mean ratios to the truth. `coherence`
/// gives the closed-form coherence from `|H|^2`.
fn welch_ratios(rec: &Record, coherence: impl Fn(f64) -> f64) -> (Ratios, FrfEstimate) {
    let dt = 1.0;
    let est = FrfParams::welch(256)
        .estimate(std::slice::from_ref(rec), dt)
        .unwrap();
    let h1 = est.spectra.h1().unwrap();
    let h2 = est.spectra.h2().unwrap();
    let hv = est.spectra.hv().unwrap();
    let coh = est.frf.coherence.as_ref().unwrap();
    let lines = est.frf.lines() as f64;
    let mut out = Ratios {
        h1: C64::new(0.0, 0.0),
        h2: C64::new(0.0, 0.0),
        hv: C64::new(0.0, 0.0),
        coherence_bias: 0.0,
        coherence_max: 0.0,
    };
    for (k, &f) in est.frf.frequency_hz.iter().enumerate() {
        let h = fir_frf(&TAPS, f, dt);
        out.h1 += h1[k][0] / h / lines;
        out.h2 += h2[k][0] / h / lines;
        out.hv += hv[k][0] / h / lines;
        let d = coh[k][0] - coherence(h.norm_sqr());
        out.coherence_bias += d / lines;
        out.coherence_max = out.coherence_max.max(d.abs());
        // Algebraic: |H1| <= |Hv| <= |H2| for any spectra with coherence <= 1
        // (relative slack for round-off).
        let (a, b, c) = (h1[k][0].norm(), hv[k][0].norm(), h2[k][0].norm());
        assert!(
            a <= b * (1.0 + 1e-12) && b <= c * (1.0 + 1e-12),
            "line {k}: {a} {b} {c}"
        );
    }
    (out, est)
}

// 400 Hann segments of 256 at 50 % overlap (399 steps of 128 plus one segment); the
// FIR's 3-sample memory at the Hann-weighted segment edges biases the estimates by < 1e-5.
const WELCH_SAMPLES: usize = 399 * 128 + 256;

#[test]
fn output_noise_leaves_h1_unbiased_and_sets_the_coherence() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let sigma_n = 0.5;
    let rec = noisy_fir_record(&mut rng, WELCH_SAMPLES, 0.0, sigma_n);
    // Gyy_signal / (Gyy_signal + Gnn) with white force of unit variance.
    let closed = |h2: f64| h2 / (h2 + sigma_n * sigma_n);
    let (ratios, est) = welch_ratios(&rec, closed);
    assert_eq!(est.frf.averages, Some(400));
    println!(
        "output noise: mean H1/H = {:.4}, H2/H = {:.4}, Hv/H = {:.4}, coherence bias {:.4}, max {:.4}",
        ratios.h1, ratios.h2, ratios.hv, ratios.coherence_bias, ratios.coherence_max
    );
    // Per line, the relative random error of H1 is sqrt((1-g2)/(2 n g2)) <= 0.045 here
    // (|H|^2 in [0.16, 1.69], so g2 >= 0.39; n ~ 380 effective); over 129 lines (~65
    // independent under Hann) the mean has a standard error below 0.006: 0.02 is over
    // three of them, and far from any biased estimator.
    assert!((ratios.h1 - 1.0).norm() < 0.02);
    // H2 is biased high by 1 + Gnn / Gyy_signal = 1 + 0.25 / |H|^2, whose mean over the
    // lines is 1.30 (measured 1.31).
    assert!((ratios.h2.re - 1.30).abs() < 0.05);
    // Coherence: the estimate's bias is ~ (1-g2)^2 / n < 0.002 and its random error per
    // line ~ sqrt(2) g (1-g2) / sqrt(n) < 0.03; 0.01 on the mean and 0.12 (4 sigma) on
    // the worst line.
    assert!(ratios.coherence_bias.abs() < 0.01);
    assert!(ratios.coherence_max < 0.12);
}

#[test]
fn input_noise_biases_h1_by_the_closed_form_and_leaves_h2_unbiased() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let sigma_n = 0.5;
    let rec = noisy_fir_record(&mut rng, WELCH_SAMPLES, sigma_n, 0.0);
    // Measured force x + n: the coherence is Gxx / (Gxx + Gnn) at every line.
    let bias = 1.0 / (1.0 + sigma_n * sigma_n);
    let (ratios, _) = welch_ratios(&rec, |_| bias);
    println!(
        "input noise: mean H1/H = {:.4} (closed form {bias:.4}), H2/H = {:.4}, Hv/H = {:.4}",
        ratios.h1, ratios.h2, ratios.hv
    );
    // Random error per line sqrt((1-g2)/(2 n g2)) = 0.018 for g2 = 0.8; the mean over
    // ~65 independent lines has a standard error ~ 0.003: 0.015 is five of them.
    assert!((ratios.h1 - bias).norm() < 0.015);
    assert!((ratios.h2 - 1.0).norm() < 0.015);
    // Hv lies in between (checked per line inside welch_ratios) and strictly inside.
    assert!(ratios.hv.re > ratios.h1.re + 0.02 && ratios.hv.re < ratios.h2.re - 0.02);
    assert!(ratios.coherence_bias.abs() < 0.01);
}

#[test]
fn equal_noise_on_force_and_response_leaves_hv_unbiased() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let sigma_n = 0.4;
    let rec = noisy_fir_record(&mut rng, WELCH_SAMPLES, sigma_n, sigma_n);
    let (ratios, _) = welch_ratios(&rec, |h2| {
        // |Gyx|^2 / (Gxx Gyy) with Gxx = 1 + s^2, Gyy = |H|^2 + s^2, |Gyx|^2 = |H|^2.
        h2 / ((1.0 + sigma_n * sigma_n) * (h2 + sigma_n * sigma_n))
    });
    println!(
        "equal noise: mean H1/H = {:.4}, H2/H = {:.4}, Hv/H = {:.4}",
        ratios.h1, ratios.h2, ratios.hv
    );
    // Hv's expectation is exact here (smallest eigenvector of G + s^2 I); its random
    // error is comparable to H1's (~0.02 per line): 0.015 on the mean.
    assert!((ratios.hv - 1.0).norm() < 0.015);
    // H1 low by 1/(1 + 0.16) = 0.862; H2 high.
    assert!((ratios.h1.re - 1.0 / (1.0 + sigma_n * sigma_n)).abs() < 0.015);
    assert!(ratios.h2.re > 1.1);
    assert!(ratios.coherence_bias.abs() < 0.01);
}

/// Variance of `|H1|` over independent estimates falls as 1/n_avg: pooled over lines,
/// normalized by the closed form `(1 - g2) / g2`.
#[test]
fn h1_variance_falls_with_the_number_of_averages() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let sigma_n = 0.5;
    let mut normalized = Vec::new();
    for segments in [10, 40, 160] {
        let mut sum = 0.0;
        let mut count = 0.0;
        let mut navg = 0;
        for _ in 0..8 {
            let rec = noisy_fir_record(&mut rng, (segments + 1) * 128, 0.0, sigma_n);
            let est = FrfParams::welch(256)
                .estimate(std::slice::from_ref(&rec), 1.0)
                .unwrap();
            navg = est.frf.averages.unwrap();
            for (k, &f) in est.frf.frequency_hz.iter().enumerate() {
                let h = fir_frf(&TAPS, f, 1.0);
                let g2 = h.norm_sqr() / (h.norm_sqr() + sigma_n * sigma_n);
                let e = (est.frf.values[k][0].norm() - h.norm()) / h.norm();
                sum += e * e / ((1.0 - g2) / g2);
                count += 1.0;
            }
        }
        assert_eq!(navg, segments);
        // Bendat & Piersol: var(|H|)/|H|^2 ~ (1-g2) / (2 n g2); Hann at 50 % overlap has
        // slightly fewer effective averages than segments.
        let var_times_2n = sum / count * 2.0 * segments as f64;
        println!("n_avg = {segments}: 2 n var / ((1-g2)/g2) = {var_times_2n:.3}");
        normalized.push(var_times_2n);
    }
    // "Loosely": within 40 % of the first-order formula, and of each other (each pooled
    // variance has ~ 8 x 65 independent lines, a few percent of sampling error; the
    // first-order formula is itself ~10 % off at n = 10).
    for &v in &normalized {
        assert!(v > 0.7 && v < 1.4, "{normalized:?}");
    }
    assert!(normalized[0] / normalized[2] < 1.4 && normalized[2] / normalized[0] < 1.4);
}

// ---------------------------------------------------------------- several references

/// Two uncorrelated white forces, three responses through FIR filters, noise on the
/// responses: H1 unbiased, multiple coherence = closed form; H2 refused (3 != 2); with
/// two responses and input noise H2 unbiased; Hv unbiased with equal noise on all.
#[test]
fn several_references() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let n = WELCH_SAMPLES;
    let taps: Vec<Vec<Vec<f64>>> = (0..3)
        .map(|_| (0..2).map(|_| white(&mut rng, 3, 0.6)).collect())
        .collect();
    let truth = |f: f64, m: usize| DMatrix::from_fn(m, 2, |i, j| fir_frf(&taps[i][j], f, 1.0));
    let make = |rng: &mut ChaCha8Rng, m: usize, input_noise: f64, output_noise: f64| {
        let x: Vec<Vec<f64>> = (0..2).map(|_| white(rng, n, 1.0)).collect();
        let y: Vec<Vec<f64>> = (0..m)
            .map(|i| {
                let a = fir(&x[0], &taps[i][0]);
                let b = fir(&x[1], &taps[i][1]);
                let clean: Vec<f64> = a.iter().zip(&b).map(|(p, q)| p + q).collect();
                add_noise(rng, &clean, output_noise)
            })
            .collect();
        let xm: Vec<Vec<f64>> = x.iter().map(|v| add_noise(rng, v, input_noise)).collect();
        record(&xm, &y)
    };
    // Mean over lines and entries of estimate / truth.
    let mean_ratio = |est: &[DMatrix<C64>], freqs: &[f64], m: usize| {
        let mut s = C64::new(0.0, 0.0);
        for (h, &f) in est.iter().zip(freqs) {
            let t = truth(f, m);
            for i in 0..m {
                for j in 0..2 {
                    s += h[(i, j)] / t[(i, j)];
                }
            }
        }
        s / (freqs.len() * m * 2) as f64
    };

    let sigma = 0.3;
    let rec = make(&mut rng, 3, 0.0, sigma);
    let est = FrfParams::welch(256)
        .estimate(std::slice::from_ref(&rec), 1.0)
        .unwrap();
    let r1 = mean_ratio(&est.frf.values, &est.frf.frequency_hz, 3);
    let mut coh_bias = 0.0;
    for (k, &f) in est.frf.frequency_hz.iter().enumerate() {
        let t = truth(f, 3);
        for i in 0..3 {
            let s = t.row(i).norm_squared();
            coh_bias += (est.multiple_coherence[k][i] - s / (s + sigma * sigma))
                / (3 * est.frf.lines()) as f64;
        }
    }
    println!(
        "2 references, output noise: mean H1/H = {r1:.4}, multiple coherence bias {coh_bias:.4}"
    );
    // Ratios near FIR zeros have heavy tails, but with 400 averages and coherences above
    // ~0.2 the mean over 129 lines x 6 entries stays within ~0.01 of its expectation.
    assert!((r1 - 1.0).norm() < 0.03);
    // Multiple coherence with 2 references is biased up by ~ r (1-g2) / n < 0.005.
    assert!(coh_bias.abs() < 0.01);
    assert!(matches!(
        FrfParams::welch(256)
            .estimator(Estimator::H2)
            .estimate(std::slice::from_ref(&rec), 1.0),
        Err(FrfEstimateError::H2NotSquare {
            outputs: 3,
            references: 2
        })
    ));
    assert!(matches!(
        est.spectra.h2(),
        Err(FrfEstimateError::H2NotSquare { .. })
    ));

    let rec = make(&mut rng, 2, sigma, 0.0);
    let est = FrfParams::welch(256)
        .estimator(Estimator::H2)
        .estimate(&[rec], 1.0)
        .unwrap();
    let r2 = mean_ratio(&est.frf.values, &est.frf.frequency_hz, 2);
    let r1 = mean_ratio(&est.spectra.h1().unwrap(), &est.frf.frequency_hz, 2);
    println!("2 references, input noise: mean H2/H = {r2:.4}, H1/H = {r1:.4}");
    // As above; H1 sits at 1/(1 + 0.09) = 0.917 for uncorrelated references.
    assert!((r2 - 1.0).norm() < 0.03);
    assert!((r1 - 1.0 / (1.0 + sigma * sigma)).norm() < 0.03);

    let rec = make(&mut rng, 3, sigma, sigma);
    let est = FrfParams::welch(256)
        .estimator(Estimator::Hv)
        .estimate(&[rec], 1.0)
        .unwrap();
    let rv = mean_ratio(&est.frf.values, &est.frf.frequency_hz, 3);
    let r1 = mean_ratio(&est.spectra.h1().unwrap(), &est.frf.frequency_hz, 3);
    println!("2 references, equal noise: mean Hv/H = {rv:.4}, H1/H = {r1:.4}");
    assert!((rv - 1.0).norm() < 0.03);
    assert!((r1 - 1.0 / (1.0 + sigma * sigma)).norm() < 0.03);
}

/// The eigenvector form of Hv reduces to the closed form for one reference, and
/// |H1| <= |Hv| <= |H2| on arbitrary spectra.
#[test]
fn hv_eigenvector_and_closed_form_agree() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    for case in 0..200 {
        // Spectra of a few random blocks, channel scales spread over 1e-3..1e3.
        let sx = 10f64.powf(3.0 * normal(&mut rng).clamp(-1.0, 1.0));
        let sy = 10f64.powf(3.0 * normal(&mut rng).clamp(-1.0, 1.0));
        let (mut gxx, mut gyx, mut gyy) = (0.0, C64::new(0.0, 0.0), 0.0);
        for _ in 0..3 {
            let x = C64::new(normal(&mut rng), normal(&mut rng)) * sx;
            let y = C64::new(normal(&mut rng), normal(&mut rng)) * sy;
            gxx += x.norm_sqr();
            gyx += y * x.conj();
            gyy += y.norm_sqr();
        }
        let closed = hv_one_reference(gxx, gyx, gyy).unwrap();
        let eig = hv_eigen(
            &DMatrix::from_element(1, 1, C64::new(gxx, 0.0)),
            &DVector::from_element(1, gyx),
            gyy,
        )
        .unwrap()[0];
        // The eigensolver is backward stable relative to ||G|| ~ max(gxx, gyy); the
        // eigenvector's ratio then carries ~1e-16 * ||G|| / gap, up to 1e-9 for these
        // scale spreads.
        assert!(
            (closed - eig).norm() <= 1e-8 * closed.norm(),
            "case {case}: {closed} vs {eig}"
        );
        let (h1, h2) = (gyx.norm() / gxx, gyy / gyx.norm());
        assert!(h1 <= closed.norm() * (1.0 + 1e-12) && closed.norm() <= h2 * (1.0 + 1e-12));
    }
    // Degenerate: no response power gives 0; no cross-spectrum with more response than
    // force power is undefined.
    assert_eq!(
        hv_one_reference(1.0, C64::new(0.0, 0.0), 0.0),
        Some(C64::new(0.0, 0.0))
    );
    assert_eq!(hv_one_reference(1.0, C64::new(0.0, 0.0), 2.0), None);
}

// ---------------------------------------------------------------- errors

fn params_error(p: FrfParams) -> String {
    match p.check() {
        Err(FrfEstimateError::InvalidParams { reason }) => reason,
        other => panic!("{p:?}: expected InvalidParams, got {other:?}"),
    }
}

#[test]
fn bad_parameters_are_refused_by_check() {
    let welch = |segment_len, overlap| {
        FrfParams::welch(16).averaging(Averaging::Welch(WelchAveraging {
            segment_len,
            overlap,
            window: SegmentWindow::Hann,
        }))
    };
    assert!(params_error(welch(1, 0.5)).contains("segment_len"));
    assert!(params_error(welch(16, 1.0)).contains("overlap"));
    assert!(params_error(welch(16, f64::NAN)).contains("overlap"));
    assert!(params_error(welch(16, -0.1)).contains("overlap"));
    assert!(params_error(welch(2, 0.8)).contains("no step"));
    assert!(params_error(FrfParams::hits().band_hz(5.0, 1.0)).contains("band"));
    assert!(params_error(FrfParams::hits().band_hz(-1.0, 1.0)).contains("band"));
    let hits = |h: HitAveraging| FrfParams::hits().averaging(Averaging::Hits(h));
    assert!(
        params_error(hits(HitAveraging {
            block_len: Some(1),
            ..HitAveraging::default()
        }))
        .contains("block_len")
    );
    for e in [
        ExponentialWindow::EndAmplitude(0.0),
        ExponentialWindow::EndAmplitude(1.0),
        ExponentialWindow::EndAmplitude(f64::NAN),
        ExponentialWindow::TimeConstant(0.0),
        ExponentialWindow::TimeConstant(f64::INFINITY),
    ] {
        assert!(
            params_error(hits(HitAveraging {
                exponential_window: Some(e),
                ..HitAveraging::default()
            }))
            .contains("exponential")
        );
    }
    let fw = ForceWindow {
        before_peak_s: 0.0,
        after_peak_s: -1.0,
        taper_s: 0.0,
    };
    assert!(
        params_error(hits(HitAveraging {
            force_window: Some(fw),
            ..HitAveraging::default()
        }))
        .contains("after_peak_s")
    );
    FrfParams::hits().check().unwrap();
    FrfParams::welch(256).check().unwrap();
}

#[test]
fn bad_data_errors_name_the_record_channel_or_line() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let good = |rng: &mut ChaCha8Rng, n: usize| {
        record(
            &[white(rng, n, 1.0)],
            &[white(rng, n, 1.0), white(rng, n, 1.0)],
        )
    };
    let dt = 0.01;

    let mut recs = vec![good(&mut rng, 64), good(&mut rng, 64)];
    recs[1].outputs[(1, 7)] = f64::NAN;
    match FrfParams::hits().estimate(&recs, dt) {
        Err(FrfEstimateError::Data(DataError::NonFinite {
            record: 1,
            channel: Channel::Output(1),
            sample: 7,
            ..
        })) => {}
        other => panic!("{other:?}"),
    }

    let mut recs = vec![good(&mut rng, 64), good(&mut rng, 64)];
    recs[1].inputs.fill(0.0);
    assert_eq!(
        FrfParams::hits().estimate(&recs, dt),
        Err(FrfEstimateError::Data(DataError::NoExcitation {
            record: 1
        }))
    );

    let recs = vec![record(
        &[white(&mut rng, 64, 1.0), vec![0.0; 64]],
        &[white(&mut rng, 64, 1.0)],
    )];
    assert_eq!(
        FrfParams::hits().estimate(&recs, dt),
        Err(FrfEstimateError::DeadReference { channel: 1 })
    );

    let recs = vec![good(&mut rng, 64), good(&mut rng, 40)];
    let err = FrfParams::welch(48).estimate(&recs, dt).unwrap_err();
    assert_eq!(
        err,
        FrfEstimateError::Data(DataError::TooShort {
            record: 1,
            samples: 40,
            required: 48,
            reason: "one Welch segment"
        })
    );
    assert!(err.to_string().contains("record 1"), "{err}");
    assert_eq!(
        FrfParams::hits().estimate(&recs, dt),
        Err(FrfEstimateError::UnequalHitLengths {
            record: 1,
            samples: 40,
            expected: 64
        })
    );
    let padded = |n| {
        FrfParams::hits().averaging(Averaging::Hits(HitAveraging {
            block_len: Some(n),
            ..HitAveraging::default()
        }))
    };
    assert_eq!(
        padded(50).estimate(&recs, dt),
        Err(FrfEstimateError::HitLongerThanBlock {
            record: 0,
            samples: 64,
            block_len: 50
        })
    );
    assert!(padded(64).estimate(&recs, dt).is_ok());
    let single = vec![good(&mut rng, 64), good(&mut rng, 1)];
    assert_eq!(
        padded(64).estimate(&single, dt),
        Err(FrfEstimateError::Data(DataError::TooShort {
            record: 1,
            samples: 1,
            required: 2,
            reason: "one FFT block"
        }))
    );
    assert!(matches!(
        FrfParams::hits()
            .band_hz(100.0, 200.0)
            .estimate(&recs[..1], dt),
        Err(FrfEstimateError::EmptyBand { .. })
    ));
    assert!(matches!(
        FrfParams::hits().estimate(&recs, 0.0),
        Err(FrfEstimateError::Data(
            DataError::InvalidSampleInterval { .. }
        ))
    ));

    // Two identical force channels: Gxx is singular at every line.
    let x = white(&mut rng, 64, 1.0);
    let recs = vec![record(&[x.clone(), x], &[white(&mut rng, 64, 1.0)])];
    match FrfParams::hits().estimate(&recs, dt) {
        Err(FrfEstimateError::SingularForces { line: 0, .. }) => {}
        other => panic!("{other:?}"),
    }

    // A two-sample rectangular pulse has no power at Nyquist: line 4 of 0..=4.
    let mut x = vec![0.0; 8];
    x[2] = 1.0;
    x[3] = 1.0;
    let recs = vec![record(&[x], &[white(&mut rng, 8, 1.0)])];
    for estimator in [Estimator::H1, Estimator::H2, Estimator::Hv] {
        let err = FrfParams::hits()
            .estimator(estimator)
            .estimate(&recs, dt)
            .unwrap_err();
        assert!(
            matches!(err, FrfEstimateError::NoForcePower { line: 4, .. }),
            "{estimator}: {err:?}"
        );
        assert!(err.to_string().contains("50 Hz"), "{err}");
        // Excluding the line with a band makes it work.
        FrfParams::hits()
            .estimator(estimator)
            .band_hz(0.0, 40.0)
            .estimate(&recs, dt)
            .unwrap();
    }
}
