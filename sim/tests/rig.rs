//! Rig effects against closed forms: accelerometer resonance, extra modes,
//! force filters, channel gain/offset/drift, coloured noise, sensor masses.

mod common;

use std::f64::consts::PI;

use common::*;
use num_complex::Complex64;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use sim::{ColouredNoise, Model, NoiseSpectrum, Plant, RigSettings, StructureSpec};

fn rig(toml_text: &str) -> RigSettings {
    toml::from_str(toml_text).unwrap()
}

/// A hammer campaign on floor `floor` with the given extra TOML (rig or
/// noise tables) appended.
fn hammer_campaign(floor: usize, samples: usize, extra: &str) -> String {
    format!(
        r#"
hits = 3
[hammer]
floor = {floor}
duration_s = 0.003
peak_n = 15.0
peak_variation = 0.1
start_jitter_s = 0.015625
[sampling]
sample_rate_hz = 64.0
samples = {samples}
pretrigger_samples = 32
{extra}
"#
    )
}

fn sine_campaign(frequency_hz: f64, extra: &str) -> String {
    format!(
        r#"
hits = 1
[hammer]
floor = 1
duration_s = 0.003
peak_n = 1.0
[excitation]
kind = "chirp"
floor = 1
amplitude_n = 1.0
start_frequency_hz = {frequency_hz}
end_frequency_hz = {frequency_hz}
duration_s = 100.0
{extra}
"#
    )
}

#[test]
fn accelerometer_resonance_has_its_closed_form_response() {
    let model = three_dof(2.0, 1e-3);
    let (fs, zeta) = (12.0, 0.05);
    let with = rig(&format!(
        "accelerometer = {{ resonance_hz = {fs}, damping_ratio = {zeta} }}"
    ));
    let bare = Plant::bare(&model, 0);
    let plant = Plant::new(&model, 0, &with);
    for r in [0.05, 0.3, 1.0, 2.5] {
        let f = r * fs;
        let (hb, hw) = (bare.frf(f), plant.frf(f));
        // w_s^2 / (w_s^2 - w^2 + 2 i zeta w_s w) = 1 / (1 - r^2 + 2 i zeta r):
        // -i / (2 zeta) at resonance.
        let sensor = Complex64::new(1.0, 0.0) / Complex64::new(1.0 - r * r, 2.0 * zeta * r);
        assert_eq!(hw[0], hb[0], "the force channel is untouched");
        for j in 1..=3 {
            // Two LU solves of well-conditioned 6x6 and 12x12 systems.
            assert!(
                (hw[j] / hb[j] - sensor).norm() < 1e-11 * sensor.norm(),
                "r = {r}, channel {j}: {} vs {sensor}",
                hw[j] / hb[j]
            );
        }
    }
    // The same through the simulated records: steady-state sines at the
    // resonance, with and without the sensor.
    let fit = |extra: &str| {
        let sim = simulator(model.clone(), &sine_campaign(fs, extra));
        let c = sim.simulate(1);
        c.hits[0]
            .accelerations
            .iter()
            .map(|a| fit_sine(a, 1.0 / 64.0, fs, 0.5, 1408..1984))
            .collect::<Vec<_>>()
    };
    let plain = fit("");
    let sensed = fit(&format!(
        "[rig]\naccelerometer = {{ resonance_hz = {fs}, damping_ratio = {zeta} }}"
    ));
    for (a, b) in plain.iter().zip(&sensed) {
        let ratio = b / a;
        // Magnitude 1 / (2 zeta) = 10, phase -90 degrees. The only
        // difference from the closed form is the aliased images of the
        // linearly interpolated force (about 1e-7, see SignalEngine), which
        // the sensor attenuates differently: 1e-6.
        assert!(
            (ratio - Complex64::new(0.0, -1.0 / (2.0 * zeta))).norm() < 1e-6 / (2.0 * zeta),
            "{ratio}"
        );
    }
}

#[test]
fn extra_mode_adds_its_modal_term_and_a_peak_at_its_frequency() {
    let model = paper_case1();
    let text = r#"
[[extra_modes]]
label = "torsion"
frequency_hz = 16.0
damping_ratio = 0.01
modal_mass_kg = 0.2
input_participation = 0.5
sensor_participation = [0.5, -0.8]
"#;
    let settings = rig(text);
    let bare = Plant::bare(&model, 0);
    let plant = Plant::new(&model, 0, &settings);
    let w = 2.0 * PI * 16.0;
    for f in [1.0, 9.0, 15.9, 16.0, 24.0] {
        let s = Complex64::new(0.0, 2.0 * PI * f);
        let term = s * s / (s * s + 2.0 * 0.01 * w * s + w * w);
        let (hb, hp) = (bare.frf(f), plant.frf(f));
        for (j, phi) in [0.5, -0.8].iter().enumerate() {
            let want = phi * 0.5 / 0.2 * term;
            // LU solves of 4x4 and 6x6 systems: rounding of the larger of
            // the two terms.
            let scale = want.norm() + hb[j + 1].norm();
            assert!(
                (hp[j + 1] - hb[j + 1] - want).norm() < 1e-12 * scale,
                "{f} Hz, floor {}",
                j + 1
            );
        }
    }
    let truth = sim::RigTruth::new(&settings, 2);
    assert_eq!(truth.extra_modes[0].label, "torsion");
    assert_eq!(
        truth.extra_modes[0].modal_constants_per_kg,
        vec![1.25, -2.0]
    );
    let pole = truth.extra_modes[0].pole_rad_s;
    assert!(
        (pole[0] + 0.01 * w).abs() < 1e-12 && (pole[1] - w * (1.0 - 1e-4f64).sqrt()).abs() < 1e-9
    );
    // Records: the acceleration spectrum of a hit peaks at the mode (the
    // hammer spectrum is flat to 1e-3 up to 25 Hz for a 3 ms pulse).
    let spectrum_peak = |extra: &str| -> (f64, f64) {
        let sim = simulator(model.clone(), &hammer_campaign(1, 2048, extra));
        let c = sim.simulate(2);
        let psd = welch_psd(&[&c.hits[0].accelerations[1]], 64.0, 2048);
        let (k0, k1) = (14 * 32, 18 * 32);
        let (k, p) = psd[k0..k1]
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (i, &p)| if p > b.1 { (i + k0, p) } else { b });
        let edge = psd[k0].max(psd[k1 - 1]);
        (k as f64 / 32.0, p / edge)
    };
    let (f_peak, prominence) = spectrum_peak(&format!(
        "[rig]\n{}",
        text.replace("[[extra_modes]]", "[[rig.extra_modes]]")
    ));
    // Peak of s^2 / (s^2 + 2 zeta w s + w^2) at f_n / sqrt(1 - 2 zeta^2)
    // = 16.0016 Hz; bins are 1/32 Hz and the Hann window's main lobe is
    // two bins wide: within one bin.
    assert!((f_peak - 16.0).abs() <= 1.0 / 32.0, "peak at {f_peak} Hz");
    assert!(
        prominence > 100.0,
        "peak only {prominence} above the band edges"
    );
    let (_, bare_prominence) = spectrum_peak("");
    // Without the mode the 14-18 Hz band falls off monotonically from the
    // 9 Hz mode: its maximum is a band edge.
    assert!(bare_prominence <= 1.0, "{bare_prominence}");
}

/// Worst H1 error of a campaign against the recorded FRF ratio, measured
/// against the FRF plus its largest alias (as in the bare chain test).
fn worst_h1_error(sim: &sim::Simulator, records: &[Vec<Vec<f64>>], fs: f64, n: usize) -> f64 {
    let mut worst = 0.0f64;
    for out in 1..records[0].len() {
        let h = h1(records, out);
        for (k, hk) in h.iter().enumerate().take(n / 2).skip(1) {
            let f = k as f64 * fs / n as f64;
            if f > 0.8 * fs / 2.0 {
                break;
            }
            let frf = sim.recorded_frf(f);
            let truth = frf[out] / frf[0];
            let alias = (1..=8)
                .flat_map(|m| [fs * m as f64 - f, fs * m as f64 + f])
                .map(|fa| sim.recorded_frf(fa)[out].norm() / frf[0].norm())
                .fold(0.0f64, f64::max);
            worst = worst.max((hk - truth).norm() / (truth.norm() + alias));
        }
    }
    worst
}

#[test]
fn hammer_records_through_the_rig_follow_the_recorded_frf() {
    // Damping high enough that 128 s records hold the whole decay, as in
    // the bare chain test; extra mode, accelerometer and a force
    // transducer low-pass all on.
    let model = three_dof(0.6, 6e-4);
    let extra = r#"
[rig]
accelerometer = { resonance_hz = 22.0, damping_ratio = 0.2 }
force_filter = { corner_hz = 15.0, order = 2, applies_to = "measured" }
[[rig.extra_modes]]
frequency_hz = 13.0
damping_ratio = 0.03
modal_mass_kg = 0.5
input_participation = 0.4
sensor_participation = [0.4, 0.1, -0.7]
"#;
    let n = 8192;
    let sim = simulator(model.clone(), &hammer_campaign(1, n, extra));
    let records = records(&sim.simulate(7));
    let worst = worst_h1_error(&sim, &records, 64.0, n);
    // Aliasing through the FIR stop band, as in the bare chain test
    // (2.2e-5 there); the accelerometer resonance attenuates the
    // high-frequency content that aliases: measured 6e-7 here.
    assert!(worst < 1e-5, "worst relative H1 error {worst:e}");
    // And the ratio really is not the structure's accelerance: the rig
    // changes it by far more than the tolerance.
    let frf = sim.recorded_frf(10.0);
    let acc = accelerance(&model, 0, 10.0);
    assert!((frf[1] / frf[0] - acc[0]).norm() > 0.1 * acc[0].norm());
}

#[test]
fn held_records_through_the_rig_follow_the_zoh_relation() {
    // Held acquisition with an extra mode and the force filter on the
    // applied force: the exact ZOH relation of the plant, computed here
    // from its matrices: y = (C (zI - Phi)^-1 Gamma + D) u.
    let model = three_dof(0.6, 6e-4);
    let extra = r#"
[acquisition]
kind = "held"
[rig]
force_filter = { corner_hz = 10.0, order = 3, applies_to = "applied" }
[[rig.extra_modes]]
frequency_hz = 13.0
damping_ratio = 0.03
modal_mass_kg = 0.5
input_participation = 0.4
sensor_participation = [0.4, 0.1, -0.7]
"#;
    let n = 8192;
    let sim = simulator(model, &hammer_campaign(2, n, extra));
    let plant = sim.plant();
    let records = records(&sim.simulate(3));
    let ns = plant.states();
    let dt = 1.0 / 64.0;
    let mut aug = nalgebra::DMatrix::zeros(ns + 1, ns + 1);
    aug.view_mut((0, 0), (ns, ns)).copy_from(&plant.a);
    aug.view_mut((0, ns), (ns, 1)).copy_from(&plant.b);
    let e = (aug * dt).exp();
    let to_c = |m: nalgebra::DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
    let phi = to_c(e.view((0, 0), (ns, ns)).into_owned());
    let gamma = to_c(e.view((0, ns), (ns, 1)).into_owned());
    // The recorded force is the filtered force, not the held one: compare
    // every channel's transfer from the held force. The held force itself
    // is not recorded, so use channel ratios: H_j / H_0.
    for out in 1..=3 {
        let h = h1(&records, out);
        for (k, hk) in h.iter().enumerate().take(n / 2).skip(1).step_by(7) {
            let z = Complex64::from_polar(1.0, 2.0 * PI * k as f64 / n as f64);
            let x = (nalgebra::DMatrix::<Complex64>::identity(ns, ns) * z - &phi)
                .lu()
                .solve(&gamma)
                .unwrap();
            let y = to_c(plant.c.clone()) * x;
            let truth = (y[(out, 0)] + plant.d[(out, 0)]) / (y[(0, 0)] + plant.d[(0, 0)]);
            // Exact discrete relation; leakage below e^{-40} and rounding:
            // measured at most 2e-10 (at the lowest bin), 1e-14 elsewhere.
            assert!(
                ((hk - truth) / truth).norm() < 1e-8,
                "channel {out}, bin {k}: {hk} vs {truth}"
            );
        }
    }
}

#[test]
fn force_filter_shapes_the_measured_or_the_applied_force() {
    let model = paper_case1();
    let bare = Plant::bare(&model, 0);
    for (target, f) in [("measured", 3.0), ("applied", 3.0), ("measured", 20.0)] {
        let p = Plant::new(
            &model,
            0,
            &rig(&format!(
                "force_filter = {{ corner_hz = {f}, order = 2, applies_to = \"{target}\" }}"
            )),
        );
        let (hb, hp) = (bare.frf(f), p.frf(f));
        // Butterworth at its corner: 1 / (i sqrt(2) - 1 + ...) has magnitude
        // 1 / sqrt(2) and phase -90 degrees for order 2.
        let bw = butterworth_gain(2, f, Complex64::new(0.0, 2.0 * PI * f));
        assert!((hp[0] - bw).norm() < 1e-12, "{target}: force {}", hp[0]);
        assert!((bw.norm() - 0.5f64.sqrt()).abs() < 1e-12);
        for j in 1..=2 {
            let ratio = hp[j] / hb[j];
            let want = if target == "applied" {
                // The structure sees the filtered force.
                bw
            } else {
                Complex64::new(1.0, 0.0)
            };
            assert!((ratio - want).norm() < 1e-11, "{target} floor {j}: {ratio}");
        }
    }
}

#[test]
fn channel_gain_offset_and_drift_are_exact() {
    let model = paper_case1();
    let noise = "[noise]\nfraction = 0.01\nabsolute_acceleration_m_s2 = 0.002";
    let plain = simulator(model.clone(), &hammer_campaign(1, 1024, noise)).simulate(4);
    let errs = format!(
        "{noise}\n[[rig.channels]]\nchannel = \"acc2\"\noffset = 0.3\ndrift_per_s = 0.01\n\
         [[rig.channels]]\nchannel = \"force\"\noffset = -0.2\n\
         [[rig.channels]]\nchannel = \"acc1\"\ngain = 1.05"
    );
    let sim = simulator(model, &hammer_campaign(1, 1024, &errs));
    let with = sim.simulate(4);
    let dt = 1.0 / 64.0;
    for (a, b) in plain.hits.iter().zip(&with.hits) {
        assert_eq!(a.pulses, b.pulses);
        for k in 0..1024 {
            let t = k as f64 * dt;
            // Offset and drift are added after the noise, whose draws do not
            // change: the difference is exact up to the rounding of one
            // addition (1e-15 of the values).
            let d2 = b.accelerations[1][k] - a.accelerations[1][k];
            assert!(
                (d2 - (0.3 + 0.01 * t)).abs() < 1e-13,
                "acc2 sample {k}: {d2}"
            );
            let d0 = b.force[k] - a.force[k];
            assert!((d0 + 0.2).abs() < 1e-13, "force sample {k}: {d0}");
        }
        // Least-squares line through the difference: intercept and slope.
        let diff: Vec<f64> = (0..1024)
            .map(|k| b.accelerations[1][k] - a.accelerations[1][k])
            .collect();
        let (n, st, st2) = (
            1024.0,
            (0..1024).map(|k| k as f64 * dt).sum::<f64>(),
            (0..1024).map(|k| (k as f64 * dt).powi(2)).sum::<f64>(),
        );
        let (sy, sty) = (
            diff.iter().sum::<f64>(),
            diff.iter()
                .enumerate()
                .map(|(k, v)| k as f64 * dt * v)
                .sum::<f64>(),
        );
        let slope = (n * sty - st * sy) / (n * st2 - st * st);
        let intercept = (sy - slope * st) / n;
        assert!((slope - 0.01).abs() < 1e-12 && (intercept - 0.3).abs() < 1e-12);
    }
    // The gain scales the clean channel (the noise is added after it, its
    // level from the scaled channel's RMS): noise-free records differ by
    // the gain exactly (one multiplication).
    let plain_sim = simulator(paper_case1(), &hammer_campaign(1, 1024, noise));
    for (a, b) in plain_sim.clean_records(4).iter().zip(sim.clean_records(4)) {
        assert!(a[1].iter().any(|&v| v != 0.0));
        for (x, y) in a[1].iter().zip(&b[1]) {
            assert_eq!(*y, 1.05 * x);
        }
    }
    let truth = sim.rig_truth();
    assert_eq!(truth.channels.gain, vec![1.0, 1.05, 1.0]);
    assert_eq!(truth.channels.offset, vec![-0.2, 0.0, 0.3]);
    assert_eq!(truth.channels.drift_per_s, vec![0.0, 0.0, 0.01]);
    // recorded_frf includes the gain.
    let (h0, h1) = (plain_sim.recorded_frf(5.0), sim.recorded_frf(5.0));
    assert_eq!(h1[1], h0[1] * 1.05);
}

/// Exact one-sided PSD of a unit-variance AR(1) process `a`, sampled every
/// `dt`: `2 dt (1 - a^2) / |1 - a e^{-i w dt}|^2`.
fn ar1_psd(a: f64, dt: f64, f: f64) -> f64 {
    let z = Complex64::from_polar(1.0, -2.0 * PI * f * dt);
    2.0 * dt * (1.0 - a * a) / (Complex64::new(1.0, 0.0) - z * a).norm_sqr()
}

#[test]
fn coloured_noise_has_its_spectrum() {
    let dt = 1.0 / 64.0;
    let seg = 1024; // 16 s segments, 1/16 Hz bins
    for (spectrum, name) in [
        (NoiseSpectrum::LowPass { corner_hz: 1.0 }, "low-pass"),
        (
            NoiseSpectrum::Pink {
                min_frequency_hz: Some(0.1),
            },
            "pink",
        ),
    ] {
        let noise = ColouredNoise {
            spectrum,
            fraction: 0.0,
            absolute_force_n: 0.0,
            absolute_acceleration_m_s2: 1.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let len = 1 << 18;
        let x = noise.unit_samples(dt, len, &mut rng);
        let var = x.iter().map(|v| v * v).sum::<f64>() / len as f64;
        // Unit variance; the estimate from 2^18 strongly correlated samples
        // (about 2^18 / 20 independent ones for the slowest component) has a
        // relative spread of a few percent: 15 %.
        assert!((var - 1.0).abs() < 0.15, "{name}: variance {var}");
        let corners = noise.corners_hz(dt, len);
        let exact = |f: f64| {
            corners
                .iter()
                .map(|&fc| ar1_psd((-2.0 * PI * fc * dt).exp(), dt, f))
                .sum::<f64>()
                / corners.len() as f64
        };
        let psd = welch_psd(&[&x], 1.0 / dt, seg);
        // Bands of 16 bins (1 Hz) from 511 half-overlapping segments:
        // relative spread about 1 / sqrt(511 * 16 / 3) = 2 %; 10 % leaves room
        // for the Hann window's bias where the spectrum curves.
        for lo in [1usize, 2, 4, 8, 16] {
            let (a, b) = (lo * 16, lo * 16 + 16);
            let got = psd[a..b].iter().sum::<f64>() / 16.0;
            let want = (a..b).map(|k| exact(k as f64 / 16.0)).sum::<f64>() / 16.0;
            assert!(
                (got / want - 1.0).abs() < 0.1,
                "{name} {lo} Hz: {got} vs {want}"
            );
        }
        // Log-log slope of the estimate between 0.5 and 8 Hz.
        let pts: Vec<(f64, f64)> = (8..128)
            .map(|k| ((k as f64 / 16.0).log10(), psd[k].log10()))
            .collect();
        let m = pts.len() as f64;
        let (sx, sy) = pts.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
        let (sxx, sxy) = pts
            .iter()
            .fold((0.0, 0.0), |s, p| (s.0 + p.0 * p.0, s.1 + p.0 * p.1));
        let slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
        // Pink: -1 (the construction gives -0.99 +- 0.02). Low-pass with a
        // 1 Hz corner: the exact spectrum's least-squares slope over the same
        // bins is -1.60 (it bends at the corner; -2 only well above it).
        // Measured -1.000 and -1.606; the estimate's scatter is about 0.01.
        let want = if name == "pink" { -1.0 } else { -1.60 };
        assert!((slope - want).abs() < 0.05, "{name}: slope {slope}");
    }
}

#[test]
fn coloured_noise_comes_on_top_of_unchanged_white_noise() {
    let model = paper_case1();
    let white = "[noise]\nfraction = 0.01";
    let plain = simulator(model.clone(), &hammer_campaign(1, 2048, white)).simulate(6);
    let coloured = format!(
        "{white}\n[noise.coloured]\nspectrum = {{ kind = \"low-pass\", corner_hz = 1.0 }}\nfraction = 0.02"
    );
    let with = simulator(model, &hammer_campaign(1, 2048, &coloured)).simulate(6);
    let a = (-2.0 * PI / 64.0f64).exp();
    for (p, w) in plain.hits.iter().zip(&with.hits) {
        let d: Vec<f64> = w.accelerations[0]
            .iter()
            .zip(&p.accelerations[0])
            .map(|(x, y)| x - y)
            .collect();
        // The difference is the coloured noise alone: an AR(1) sequence with
        // lag-one correlation a = 0.906 (white noise left in it would pull
        // that towards 0). Its estimate from 2048 samples has spread
        // sqrt((1 - a^2) / 2048) = 0.01; 0.05 is 5 sigma.
        let r0 = d.iter().map(|v| v * v).sum::<f64>();
        let r1 = d.windows(2).map(|v| v[0] * v[1]).sum::<f64>();
        assert!((r1 / r0 - a).abs() < 0.05, "lag-1 correlation {}", r1 / r0);
    }
}

#[test]
fn sensor_masses_are_reported_apart() {
    let text = r#"
kind = "matrices"
mass = [[0.2913, 0.0153], [0.0153, 0.3387]]
stiffness = [[630.44, -425.83], [-425.83, 439.01]]
sensor_masses_kg = [0.005, 0.0045]
"#;
    let spec: StructureSpec = toml::from_str(text).unwrap();
    let m = spec.matrices().unwrap();
    assert_eq!(m.bare_mass[(0, 0)], 0.2913);
    assert_eq!(m.mass[(0, 0)], 0.2913 + 0.005);
    assert_eq!(m.mass[(1, 1)], 0.3387 + 0.0045);
    assert_eq!(m.mass[(0, 1)], 0.0153);
    assert_eq!(m.sensor_masses_kg, vec![0.005, 0.0045]);
    // Without the key: the mass as given, no sensors, and the key is not
    // written back (scenario echoes stay as they were).
    let plain: StructureSpec =
        toml::from_str(&text.replace("sensor_masses_kg = [0.005, 0.0045]", "")).unwrap();
    let mp = plain.matrices().unwrap();
    assert_eq!(mp.mass, mp.bare_mass);
    assert_eq!(mp.sensor_masses_kg, vec![0.0, 0.0]);
    assert!(!serde_json::to_string(&plain).unwrap().contains("sensor"));
    let bad: StructureSpec = toml::from_str(&text.replace("[0.005, 0.0045]", "[0.005]")).unwrap();
    assert_eq!(
        bad.matrices().unwrap_err().to_string(),
        "structure.sensor_masses_kg: has 1 entries, expected one per floor (2)"
    );
    let bad: StructureSpec =
        toml::from_str(&text.replace("[0.005, 0.0045]", "[0.005, -1.0]")).unwrap();
    assert_eq!(
        bad.matrices().unwrap_err().to_string(),
        "structure.sensor_masses_kg[1]: must be a finite number >= 0, got -1"
    );
    // Shear frame: the loaded mass is the frame's mass matrix bit for bit;
    // bare plus sensors equals it to rounding of one addition.
    let frame: StructureSpec = toml::from_str(
        r#"
kind = "shear-frame"
[[storeys]]
pillars = 4
pillar_width_m = 0.035
pillar_thickness_m = 0.001
length_m = 0.3
youngs_modulus_pa = 210e9
density_kg_m3 = 7850.0
[[storeys]]
pillars = 4
pillar_width_m = 0.035
pillar_thickness_m = 0.001
length_m = 0.35
youngs_modulus_pa = 210e9
density_kg_m3 = 7850.0
[[floors]]
block_length_m = 0.2
block_width_m = 0.045
block_height_m = 0.045
block_density_kg_m3 = 2700.0
sensor_mass_kg = 0.005
[[floors]]
block_length_m = 0.2
block_width_m = 0.045
block_height_m = 0.045
block_density_kg_m3 = 2700.0
sensor_mass_kg = 0.006
added_mass_kg = 1.0
"#,
    )
    .unwrap();
    let mf = frame.matrices().unwrap();
    let sf = match &frame {
        StructureSpec::ShearFrame { storeys, floors } => sim::ShearFrame {
            storeys: storeys.clone(),
            floors: floors.clone(),
        },
        _ => unreachable!(),
    };
    assert_eq!(mf.mass, sf.mass_matrix());
    assert_eq!(mf.sensor_masses_kg, vec![0.005, 0.006]);
    for i in 0..2 {
        let sum = mf.bare_mass[(i, i)] + mf.sensor_masses_kg[i];
        assert!((sum - mf.mass[(i, i)]).abs() <= 4.0 * f64::EPSILON * mf.mass[(i, i)]);
    }
    // The truth model built from it.
    let damping =
        sim::build_damping(&mf.mass, &mf.stiffness, &sim::DampingSpec::None, &[]).unwrap();
    Model::new(mf.mass, mf.stiffness, damping).unwrap();
}

#[test]
fn rig_settings_are_checked_with_the_field_named() {
    let bad = |extra: &str| {
        let settings: sim::CampaignSettings =
            toml::from_str(&hammer_campaign(1, 1024, extra)).unwrap();
        sim::Simulator::new(paper_case1(), settings)
            .unwrap_err()
            .to_string()
    };
    assert_eq!(
        bad("[[rig.channels]]\nchannel = \"acc3\"\noffset = 1.0"),
        "rig.channels[0].channel: unknown channel \"acc3\"; channels are \"force\" and \"acc1\" ..= \"acc2\""
    );
    assert_eq!(
        bad("[[rig.channels]]\nchannel = \"acc1\"\n[[rig.channels]]\nchannel = \"acc1\""),
        "rig.channels[1].channel: channel \"acc1\" appears twice"
    );
    assert_eq!(
        bad(
            "[[rig.extra_modes]]\nfrequency_hz = 10.0\ndamping_ratio = 0.01\nmodal_mass_kg = 1.0\ninput_participation = 1.0\nsensor_participation = [1.0]"
        ),
        "rig.extra_modes[0].sensor_participation: has 1 entries, expected one per floor (2)"
    );
    assert_eq!(
        bad("[rig]\naccelerometer = { resonance_hz = 100.0, damping_ratio = 0.0 }"),
        "rig.accelerometer.damping_ratio: must be a finite number > 0, got 0"
    );
    assert_eq!(
        bad("[rig]\nforce_filter = { corner_hz = 100.0, order = 9 }"),
        "rig.force_filter.order: must be between 1 and 8, got 9"
    );
    assert_eq!(
        bad("[noise.coloured]\nspectrum = { kind = \"low-pass\", corner_hz = -1.0 }"),
        "noise.coloured.spectrum.corner_hz: must be a finite number > 0, got -1"
    );
}
