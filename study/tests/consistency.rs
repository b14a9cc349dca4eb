//! A hit that is inconsistent with the others is never used silently.
//!
//! Property: corrupt one random hit of a clean simulated campaign in one of
//! the ways a rig can (dead, re-gained, sign-flipped, delayed, offset,
//! drifting, clipped, spiked, humming, bursting, swapped, copied or
//! duplicated channels, a channel from another hit); the analysis then
//! either names that hit (a warning, a dropped hit or an error naming its
//! file) or gives M and K within the clean result's error bars.

use std::path::Path;
use std::sync::OnceLock;

use ident::Campaign;
use proptest::prelude::*;
use study::LoadedScenario;
use study::analysis::{Analysis, AnalysisSettings, analyze};

const HITS: usize = 8;

fn clean() -> &'static (Campaign, Analysis) {
    static CLEAN: OnceLock<(Campaign, Analysis)> = OnceLock::new();
    CLEAN.get_or_init(|| {
        let s = LoadedScenario::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/paper-case1.toml"),
        )
        .unwrap();
        let mut sc = s.scenario.clone();
        sc.campaign.hits = HITS;
        let c = sc
            .simulator(s.model.clone())
            .unwrap()
            .simulate(7)
            .to_ident();
        let a = analyze(&c, &AnalysisSettings::default()).unwrap();
        assert!(
            a.dropped.is_empty(),
            "the clean campaign is clean: {:?}",
            a.warnings
        );
        assert!(a.consistency.flags.is_empty(), "{:?}", a.consistency.flags);
        (c, a)
    })
}

/// One way a rig spoils a hit. Channels: 0 force, 1 acc1, 2 acc2.
#[derive(Debug, Clone)]
enum Fault {
    Dead(usize),
    Gain(usize, f64),
    SignFlip(usize),
    Delay(usize, usize),
    Offset(usize, f64),
    Drift(usize, f64),
    Clip(usize, f64),
    Spike(usize, usize, f64),
    Hum(usize, f64, f64),
    Burst(usize, usize, usize, f64),
    Swap(usize, usize),
    Copy(usize, usize),
    Duplicate(usize),
    FromOtherHit(usize, usize),
}

fn fault() -> impl Strategy<Value = Fault> {
    let ch = 0..3usize;
    prop_oneof![
        ch.clone().prop_map(Fault::Dead),
        (ch.clone(), prop_oneof![0.05..0.9f64, 1.1..20.0f64]).prop_map(|(c, g)| Fault::Gain(c, g)),
        ch.clone().prop_map(Fault::SignFlip),
        (1..3usize, 1..40usize).prop_map(|(c, d)| Fault::Delay(c, d)),
        (ch.clone(), -3.0..3.0f64).prop_map(|(c, o)| Fault::Offset(c, o)),
        (ch.clone(), -3.0..3.0f64).prop_map(|(c, d)| Fault::Drift(c, d)),
        (ch.clone(), 0.05..0.9f64).prop_map(|(c, f)| Fault::Clip(c, f)),
        (ch.clone(), 0..2048usize, 0.0..30.0f64).prop_map(|(c, i, e)| Fault::Spike(c, i, e)),
        (ch.clone(), 0.05..0.5f64, 0.01..1.0f64).prop_map(|(c, f, a)| Fault::Hum(c, f, a)),
        (ch.clone(), 0..2000usize, 1..400usize, 0.01..3.0f64)
            .prop_map(|(c, s, l, a)| Fault::Burst(c, s, l, a)),
        (ch.clone(), ch.clone())
            .prop_filter("two channels", |(a, b)| a != b)
            .prop_map(|(a, b)| Fault::Swap(a, b)),
        (ch.clone(), ch.clone())
            .prop_filter("two channels", |(a, b)| a != b)
            .prop_map(|(a, b)| Fault::Copy(a, b)),
        (0..HITS).prop_map(Fault::Duplicate),
        (ch, 0..HITS).prop_map(|(c, h)| Fault::FromOtherHit(c, h)),
    ]
}

/// Channel `c` of hit `k` as a vector.
fn get(camp: &Campaign, k: usize, c: usize) -> Vec<f64> {
    let r = &camp.records[k];
    if c == 0 {
        r.inputs.row(0).iter().copied().collect()
    } else {
        r.outputs.row(c - 1).iter().copied().collect()
    }
}

fn set(camp: &mut Campaign, k: usize, c: usize, v: &[f64]) {
    let r = &mut camp.records[k];
    for (i, x) in v.iter().enumerate() {
        if c == 0 {
            r.inputs[(0, i)] = *x;
        } else {
            r.outputs[(c - 1, i)] = *x;
        }
    }
}

fn peak(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |a: f64, x| a.max(x.abs()))
}

fn corrupt(camp: &mut Campaign, k: usize, fault: &Fault) {
    let n = camp.records[k].len();
    let map = |camp: &mut Campaign, c: usize, f: &dyn Fn(usize, f64, f64) -> f64| {
        let v = get(camp, k, c);
        let p = peak(&v);
        let w: Vec<f64> = v.iter().enumerate().map(|(i, x)| f(i, *x, p)).collect();
        set(camp, k, c, &w);
    };
    match *fault {
        Fault::Dead(c) => map(camp, c, &|_, _, _| 0.0),
        Fault::Gain(c, g) => map(camp, c, &|_, x, _| g * x),
        Fault::SignFlip(c) => map(camp, c, &|_, x, _| -x),
        Fault::Delay(c, d) => {
            let v = get(camp, k, c);
            let w: Vec<f64> = (0..n)
                .map(|i| if i >= d { v[i - d] } else { 0.0 })
                .collect();
            set(camp, k, c, &w);
        }
        Fault::Offset(c, o) => map(camp, c, &|_, x, p| x + o * p),
        Fault::Drift(c, d) => map(camp, c, &|i, x, p| x + d * p * i as f64 / n as f64),
        Fault::Clip(c, f) => map(camp, c, &|_, x, p| x.clamp(-f * p, f * p)),
        Fault::Spike(c, at, e) => map(camp, c, &|i, x, p| {
            if i == at % n { p * 10f64.powf(e) } else { x }
        }),
        Fault::Hum(c, f, a) => map(camp, c, &|i, x, p| {
            x + a * p * (2.0 * std::f64::consts::PI * f * i as f64).sin()
        }),
        Fault::Burst(c, s, l, a) => map(camp, c, &|i, x, p| {
            // Deterministic broadband burst.
            let r = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            if i >= s && i < s + l {
                x + a * p * (r - 0.5)
            } else {
                x
            }
        }),
        Fault::Swap(a, b) => {
            let (va, vb) = (get(camp, k, a), get(camp, k, b));
            set(camp, k, a, &vb);
            set(camp, k, b, &va);
        }
        Fault::Copy(from, to) => {
            let v = get(camp, k, from);
            set(camp, k, to, &v);
        }
        Fault::Duplicate(other) => {
            let other = if other == k { (k + 1) % HITS } else { other };
            camp.records[k] = camp.records[other].clone();
        }
        Fault::FromOtherHit(c, other) => {
            let other = if other == k { (k + 1) % HITS } else { other };
            let v = get(camp, other, c);
            set(camp, k, c, &v);
        }
    }
}

/// Largest deviation of `a` from `b` in units of the standard errors `sd`.
fn in_sigmas(a: &nalgebra::DMatrix<f64>, b: &nalgebra::DMatrix<f64>, sd: &[Vec<f64>]) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            worst = worst.max((a[(i, j)] - b[(i, j)]).abs() / sd[i][j]);
        }
    }
    worst
}

proptest! {
    // 96 cases: every fault kind several times over (about 7 each), in a
    // few seconds. The seed is fixed so that the suite is deterministic;
    // FRAMEID_PROP_CASES=2000 FRAMEID_PROP_SEED=<n> search deeper elsewhere.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("FRAMEID_PROP_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(96),
        rng_seed: proptest::test_runner::RngSeed::Fixed(
            std::env::var("FRAMEID_PROP_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(20261126),
        ),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn one_corrupted_hit_is_named_or_harmless(k in 0..HITS, fault in fault()) {
        let (clean_campaign, clean) = clean();
        let mut camp = clean_campaign.clone();
        corrupt(&mut camp, k, &fault);
        let label = camp.labels[k].clone();
        let settings = AnalysisSettings { uncertainty: false, ..AnalysisSettings::default() };
        match analyze(&camp, &settings) {
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.contains(&format!("{label}:")), "refused without naming {label}: {msg}");
            }
            Ok(a) => {
                let named = a.warnings.iter().any(|w| w.starts_with(&format!("{label}:")));
                if !named {
                    // Used silently: then it must not matter.
                    let u = clean.uncertainty.as_ref().expect("clean error bars");
                    let id = &a.identification;
                    let dm = in_sigmas(&id.mass, &clean.identification.mass, &u.mass.std);
                    let dk = in_sigmas(&id.stiffness, &clean.identification.stiffness, &u.stiffness.std);
                    // One standard error: "within the clean result's error bars".
                    prop_assert!(
                        dm <= 1.0 && dk <= 1.0,
                        "{fault:?} in {label} used silently: M off by {dm:.2} and K by {dk:.2} standard errors; warnings {:?}",
                        a.warnings
                    );
                }
            }
        }
    }
}

/// The one miss a 1500-case search found before the glitch check: a single
/// acc1 sample off by a tenth of the channel's peak early in the response
/// (fault `Burst(1, 146, 1, 0.2025)` on hit 1) moved K by 1.2 standard
/// errors unflagged. It is now named, with its sample.
#[test]
fn a_single_sample_glitch_is_named() {
    let (clean_campaign, _) = clean();
    let mut camp = clean_campaign.clone();
    corrupt(&mut camp, 0, &Fault::Burst(1, 146, 1, 0.202531759638919));
    let settings = AnalysisSettings {
        uncertainty: false,
        ..AnalysisSettings::default()
    };
    let a = analyze(&camp, &settings).unwrap();
    assert_eq!(a.dropped, [0], "{:?}", a.warnings);
    assert!(
        a.warnings
            .iter()
            .any(|w| w.starts_with("hit 1: channel acc1: spike: sample #147")),
        "{:?}",
        a.warnings
    );
}

/// The error bars are computed alongside the residual check of the hits; when that
/// check drops a hit, they must be those of the hits kept, not of the campaign as read.
#[test]
fn error_bars_follow_a_hit_dropped_by_the_residual_check() {
    let (clean_campaign, _) = clean();
    let mut camp = clean_campaign.clone();
    corrupt(&mut camp, 0, &Fault::Burst(1, 146, 1, 0.202531759638919));
    let a = analyze(&camp, &AnalysisSettings::default()).unwrap();
    assert_eq!(a.dropped, [0], "{:?}", a.warnings);
    let u = a.uncertainty.as_ref().expect("error bars");
    assert_eq!((u.hits, a.campaign.len()), (HITS - 1, HITS - 1));
    // The same hits without the residual check's drop: the same error bars.
    let kept = camp.subset(&(1..HITS).collect::<Vec<_>>());
    let b = analyze(&kept, &AnalysisSettings::default()).unwrap();
    assert!(b.dropped.is_empty(), "{:?}", b.warnings);
    assert_eq!(b.uncertainty.as_ref(), Some(u));
}
