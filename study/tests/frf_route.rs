//! The FRF route of the harness against the time route: simulated hits ->
//! FRFs averaged across the hits -> pLSCF, LSFD, MKR, scored like the time
//! route, on the same campaigns (`route = "both"`).

use std::path::Path;

use sim::{Model, NoiseSettings};
use study::experiment::{Routes, run_trial};
use study::score::{FrfScore, MatrixEstimate, rel_fro};
use study::sweep::Outcome;
use study::{LoadedScenario, ScoreKey};

fn scenario(name: &str) -> LoadedScenario {
    LoadedScenario::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenarios")
            .join(name),
    )
    .unwrap()
}

/// Worst relative errors of f and xi over the modes, relative Frobenius
/// errors of M, K and the MKR damping.
#[derive(Debug, Clone, Copy)]
struct Errors {
    f: f64,
    xi: f64,
    m: f64,
    k: f64,
    damping_mkr: f64,
}

fn errors(
    frequencies_hz: &[f64],
    damping_ratios: &[f64],
    mass: &nalgebra::DMatrix<f64>,
    stiffness: &nalgebra::DMatrix<f64>,
    damping_mkr: &nalgebra::DMatrix<f64>,
    model: &Model,
) -> Errors {
    let modal = model.modal().unwrap();
    let n = model.dofs();
    assert_eq!(frequencies_hz.len(), n, "every structural mode is found");
    let worst = |a: &[f64], b: &[f64]| {
        (0..n)
            .map(|j| (a[j] / b[j] - 1.0).abs())
            .fold(0.0, f64::max)
    };
    Errors {
        f: worst(frequencies_hz, &modal.frequencies_hz),
        xi: worst(damping_ratios, &modal.damping_ratios),
        m: rel_fro(mass, &model.mass),
        k: rel_fro(stiffness, &model.stiffness),
        damping_mkr: rel_fro(damping_mkr, &model.damping),
    }
}

/// Both routes on the campaign of `seed` at `noise` (fraction of each
/// channel's RMS): (time, FRF).
fn both_routes(s: &LoadedScenario, noise: f64, seed: u64) -> (Errors, Errors) {
    let sc = &s.scenario;
    let simulator = sc.simulator(s.model.clone()).unwrap();
    let identifier = sc.identifier();
    let frf = sc.frf_route();
    let trial = run_trial(
        &simulator,
        Routes {
            time: Some(&identifier),
            refiner: None,
            frf: Some(&frf),
        },
        &NoiseSettings {
            fraction: noise,
            ..Default::default()
        },
        seed,
    );
    let t = trial.identification.unwrap().unwrap();
    let f = trial.frf.unwrap().unwrap();
    (
        errors(
            &t.frequencies_hz,
            &t.damping_ratios,
            &t.mass,
            &t.stiffness,
            &t.damping_mkr,
            &s.model,
        ),
        errors(
            &f.frequencies_hz,
            &f.damping_ratios,
            &f.mass,
            &f.stiffness,
            &f.damping_mkr,
            &s.model,
        ),
    )
}

#[test]
fn noise_free_frf_route_recovers_the_truth_like_the_time_route() {
    for name in ["paper-case1.toml", "frame-three-storey.toml"] {
        let (time, frf) = both_routes(&scenario(name), 0.0, 1);
        // The tolerances of the time route's noise-free round trip of
        // analyzer records (tests/sim_roundtrip.rs, the issue's: f 0.01 %,
        // xi 1 %, M and K 0.1 %, MKR damping 1 %), for both routes on the
        // same campaign. Measured (paper case 1 / three storeys): time f
        // 1.5e-8 / 6.3e-9, xi 1.9e-6 / 5.4e-6, M 1.6e-5 / 1.6e-5, K 2.0e-5
        // / 1.4e-5, damping 9.1e-4 / 1.2e-3; FRF f 1.9e-8 / 1.9e-8, xi
        // 8.1e-7 / 1.3e-6, M 2.9e-5 / 3.9e-5, K 2.4e-5 / 3.6e-5, damping
        // 2.7e-3 / 3.0e-3. What the FRF route leaves is the records' end
        // under the exponential window (1e-3 of a tail of a few %) and the
        // residual terms' fit of the out-of-band modes.
        for (route, e) in [("time", time), ("FRF", frf)] {
            assert!(
                e.f < 1e-4 && e.xi < 1e-2 && e.m < 1e-3 && e.k < 1e-3 && e.damping_mkr < 1e-2,
                "{name}, {route} route: {e:?}"
            );
        }
        // And the FRF route is not far behind the time route: within 5x on
        // M and K (measured 1.2x to 2.6x) and on the damping (3.0x, 2.6x).
        assert!(
            frf.m < 5.0 * time.m
                && frf.k < 5.0 * time.k
                && frf.damping_mkr < 5.0 * time.damping_mkr,
            "{name}: time {time:?}, FRF {frf:?}"
        );
    }
}

/// The comparison scenario with `noise` levels and `trials` trials.
fn comparison_plan(noise: &[f64], trials: usize) -> study::sweep::Plan {
    study::sweep::Plan::new(
        &scenario("frf-vs-time.toml"),
        Some(noise),
        Some(trials),
        None,
    )
    .unwrap()
}

/// The score `key` of every successful trial at noise level `noise`
/// (index), in trial order (NaN where that route failed).
fn column(
    plan: &study::sweep::Plan,
    rows: &[study::sweep::TrialRow],
    noise: usize,
    key: ScoreKey,
) -> Vec<f64> {
    let k = plan.score_keys().iter().position(|&x| x == key).unwrap();
    rows.iter()
        .filter(|r| r.key.noise == noise)
        .filter_map(|r| match &r.outcome {
            Outcome::Ok { scores, .. } => Some(scores[k]),
            Outcome::Failed { .. } => None,
        })
        .collect()
}

/// Mean over its standard error (sample standard deviation / sqrt(n)).
fn z_score(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    mean / (sd / n.sqrt())
}

#[test]
fn with_noise_the_routes_agree_within_their_error_bars() {
    let plan = comparison_plan(&[0.01, 0.02], 20);
    let truth = study::sweep::plan_truth(&plan).unwrap();
    let rows = study::sweep::run(&plan, &truth, None, 2, &|| {}).unwrap();
    assert!(
        rows.iter()
            .all(|r| matches!(&r.outcome, Outcome::Ok { note: None, .. })),
        "every trial identified by both routes"
    );
    for (noise, level) in plan.noise_levels.iter().enumerate() {
        for &key in &plan.score_keys() {
            let ScoreKey::Entry { matrix, .. } = key else {
                continue;
            };
            let frf_key = ScoreKey::Frf(FrfScore::of_time_key(key).unwrap());
            let (time, frf) = (
                column(&plan, &rows, noise, key),
                column(&plan, &rows, noise, frf_key),
            );
            let paired: Vec<f64> = time.iter().zip(&frf).map(|(t, f)| t - f).collect();
            let z = z_score(&paired);
            if matrix == MatrixEstimate::DampingRayleigh {
                // Except the Rayleigh damping: the time route's is biased
                // high by noise (ERA's damping ratios), the FRF route's is
                // not. Measured: time minus FRF +2.0e-3 to +3.5e-3 of the
                // diagonal-scaled entries at 1 % (z 11 to 12), +8e-3 to
                // +1.5e-2 at 2 % (z 28 to 37), growing as the square of
                // the noise. The bias is pinned (z > 5, half the smallest
                // measured) and the FRF route's own mean error must stay
                // within the 4 standard errors of the other entries.
                assert!(z > 5.0, "noise {level}, {key} - {frf_key}: z = {z}");
                let z_frf = z_score(&frf);
                assert!(z_frf.abs() < 4.0, "noise {level}, {frf_key}: z = {z_frf}");
            } else {
                // 20 paired trials per level: per entry of M, K and the MKR
                // damping the mean of the trial-by-trial difference of the
                // two routes' signed errors is within 4 of its standard
                // errors (the spread over the trials) of zero. Measured
                // |z| <= 2.42 over these 18 comparisons (stiffness_22 at
                // 2 %); 4 leaves room for the 18 draws (a 4-sigma
                // excursion has probability 6e-5 each).
                assert!(z.abs() < 4.0, "noise {level}, {key} - {frf_key}: z = {z}");
            }
        }
    }
}

#[test]
fn both_routes_in_shards_merge_to_the_bytes_of_one_run() {
    use study::sweep::{Shard, execute, merge};
    let plan = comparison_plan(&[0.0, 0.02], 3);
    let path = Path::new("scenarios/frf-vs-time.toml");
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole");
    execute(path, &plan, &whole, None, 1, &|| {}).unwrap();
    let shards: Vec<_> = (1..=3)
        .map(|index| {
            let out = dir.path().join(format!("shard-{index}"));
            execute(
                path,
                &plan,
                &out,
                Some(Shard { index, count: 3 }),
                2,
                &|| {},
            )
            .unwrap();
            out
        })
        .collect();
    let merged = dir.path().join("merged");
    let parts: Vec<&Path> = shards.iter().map(|p| p.as_path()).collect();
    merge(&parts, &merged).unwrap();
    for file in [
        "trials.csv",
        "summary.json",
        "sweep.json",
        "representative.json",
    ] {
        let read = |d: &Path| std::fs::read(d.join(file)).unwrap();
        assert!(read(&whole) == read(&merged), "{file} differs");
    }
    // What was compared holds both routes' scores of every trial.
    let csv = std::fs::read_to_string(whole.join("trials.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for column in [
        "mass_err",
        "frf_mass_err",
        "frf_damping_mkr_12_err",
        "time_failed",
        "frf_failed",
    ] {
        assert!(header.contains(&column), "{column}");
    }
    assert_eq!(csv.lines().filter(|l| l.contains(",ok,")).count(), 6);
    // The report's side-by-side table: M, K, MKR and Rayleigh damping per
    // level, both routes over all 3 trials, efficiencies where there is a
    // bound (not at zero noise).
    let report = study::report::study(&whole).unwrap();
    let routes = &report.accuracy.routes;
    assert_eq!(routes.len(), 2 * 4);
    for r in routes {
        assert_eq!((r.time.trials, r.frf.trials), (3, 3), "{r:?}");
        assert!(r.time.rms >= 0.0 && r.frf.rms >= 0.0, "{r:?}");
        assert_eq!(r.time.efficiency.is_nan(), r.noise_level == 0.0, "{r:?}");
        assert_eq!(r.frf.efficiency.is_nan(), r.noise_level == 0.0, "{r:?}");
    }
    assert!(reports::render(&study::report::build("t", "c", &[&whole]).unwrap()).is_ok());
}

#[test]
fn a_failing_frf_route_leaves_the_time_route_scored() {
    // A band below the first mode (2.7 Hz): the FRF route cannot find the
    // two modes, the time route identifies as always.
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/frf-vs-time.toml"),
    )
    .unwrap()
    .replace("band_hz = [0.0, 25.0]", "band_hz = [0.0, 2.0]");
    let loaded = LoadedScenario::from_text(&text, Path::new("low-band.toml")).unwrap();
    let plan = study::sweep::Plan::new(&loaded, Some(&[0.01]), Some(2), None).unwrap();
    let truth = study::sweep::plan_truth(&plan).unwrap();
    let rows = study::sweep::run(&plan, &truth, None, 1, &|| {}).unwrap();
    let keys = plan.score_keys();
    let at = |k: ScoreKey| keys.iter().position(|&x| x == k).unwrap();
    for r in &rows {
        let Outcome::Ok { scores, note } = &r.outcome else {
            panic!("the time route identified: {:?}", r.outcome);
        };
        let (reason, message) = note.as_ref().expect("the FRF route's failure is noted");
        assert!(reason.starts_with("FRF route: "), "{reason}");
        assert!(
            message.starts_with("FRF route: FRF identification: "),
            "{message}"
        );
        assert!(scores[at(ScoreKey::Frf(FrfScore::Matrix(MatrixEstimate::Mass)))].is_nan());
        assert_eq!(
            scores[at(ScoreKey::RouteFailed(study::score::Route::Frf))],
            1.0
        );
        assert_eq!(
            scores[at(ScoreKey::RouteFailed(study::score::Route::Time))],
            0.0
        );
        // 1 % noise: M within 1 % (measured below 1e-3 in the other tests).
        assert!(scores[at(ScoreKey::Matrix(MatrixEstimate::Mass))] < 1e-2);
    }
    let summary = study::sweep::summarize(&plan, &truth, &keys, &rows);
    assert_eq!(summary.levels[0].failures, 0);
    assert_eq!(summary.levels[0].refine_failures.values().sum::<usize>(), 2);
}

#[test]
fn a_plan_takes_another_route() {
    use study::scenario::RouteSetting;
    let plan = study::sweep::Plan::new(&scenario("paper-case1.toml"), None, Some(2), None).unwrap();
    let time_keys = plan.score_keys();
    let both = plan.clone().with_route(RouteSetting::Both).unwrap();
    assert_eq!(both.score_keys()[..time_keys.len()], time_keys[..]);
    assert!(
        both.score_keys()
            .contains(&ScoreKey::Frf(FrfScore::Matrix(MatrixEstimate::Mass)))
    );
    // paper-case1.toml refines, which needs the time route.
    let err = plan.with_route(RouteSetting::Frf).unwrap_err().to_string();
    assert!(
        err.starts_with("route frf (identification.refine): "),
        "{err}"
    );
}

#[test]
fn frf_route_on_held_records_is_biased() {
    // The FRF route takes the DFT ratio of the records for the continuous
    // accelerance, which band-limited records give; held (ZOH) records give
    // the FRF of the sampled system instead, and ident's FRF route has no
    // intersample option to undo that. Measured on paper case 1, noise
    // free: M 9.6 %, K 14.7 %, MKR damping 90x its size (the time route
    // with `zoh`: 7e-14). The test pins that the bias is real (> 1 %), as
    // tests/sim_roundtrip.rs pins the time route's on the wrong assumption.
    let mut s = scenario("paper-case1.toml");
    s.scenario.campaign.acquisition = sim::Acquisition::Held;
    s.scenario.identification.intersample = Some(ident::Intersample::Zoh);
    let (time, frf) = both_routes(&s, 0.0, 1);
    // Rounding only on the time route (measured 7e-14, 3e-14, 6e-13).
    assert!(
        time.m < 1e-9 && time.k < 1e-9 && time.damping_mkr < 1e-9,
        "{time:?}"
    );
    assert!(
        frf.m > 0.01 && frf.k > 0.01 && frf.damping_mkr > 1.0,
        "{frf:?}"
    );
}
