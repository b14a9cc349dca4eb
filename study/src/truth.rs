//! `truth.json`: what a simulated campaign was simulated from.
//!
//! Matrices are arrays of rows. Modes are in ascending frequency;
//! `mode_shapes[j][i]` is the displacement of floor i + 1 in mode j + 1 as
//! `[re, im]`, scaled so the largest-magnitude component is `[1, 0]`.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use sim::{Model, Pulse};

use crate::scenario::Scenario;

/// Contents of `truth.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Version of frameid that wrote it.
    pub frameid_version: String,
    /// Scenario name.
    pub scenario: String,
    /// Seed of the campaign.
    pub seed: u64,
    /// Degrees of freedom (floors).
    pub dofs: usize,
    /// Sample interval, s.
    pub dt_s: f64,
    /// Floor hit by the hammer, 1-based; the force channel is collocated
    /// with acceleration channel `hit_floor`.
    pub hit_floor: usize,
    /// Mass matrix, kg (rows): the structure with its sensors, as
    /// simulated.
    pub mass: Vec<Vec<f64>>,
    /// Mass matrix without the sensors, kg (rows): `mass` minus
    /// `sensor_masses_kg` on the diagonal.
    pub bare_mass: Vec<Vec<f64>>,
    /// Sensor (accelerometer) mass on each floor, kg.
    pub sensor_masses_kg: Vec<f64>,
    /// Stiffness matrix, N/m (rows).
    pub stiffness: Vec<Vec<f64>>,
    /// Damping matrix, N s/m (rows).
    pub damping: Vec<Vec<f64>>,
    /// Natural frequencies, Hz, ascending.
    pub frequencies_hz: Vec<f64>,
    /// Damping ratios.
    pub damping_ratios: Vec<f64>,
    /// Mode shapes (see the module docs).
    pub mode_shapes: Vec<Vec<[f64; 2]>>,
    /// The record files and the pulses applied in each hit (no pulses for
    /// shaker excitation).
    pub hits: Vec<HitTruth>,
    /// What the rig adds that the shear model lacks (extra modes, sensor
    /// dynamics, channel errors).
    pub rig: sim::rig::RigTruth,
    /// The scenario as used (command-line overrides applied).
    pub settings: Scenario,
}

/// One hit of the campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HitTruth {
    /// The record file (name only).
    pub file: String,
    /// The pulses of the hit.
    pub pulses: Vec<Pulse>,
}

/// A matrix as an array of rows.
pub fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

impl Truth {
    /// Truth for a campaign of `model` simulated from `settings` with `seed`.
    pub fn new(
        model: &Model,
        settings: &Scenario,
        seed: u64,
        hits: Vec<HitTruth>,
    ) -> Result<Truth, sim::SimError> {
        let modal = model.modal()?;
        let structure = settings.structure.matrices()?;
        Ok(Truth {
            frameid_version: env!("CARGO_PKG_VERSION").to_string(),
            scenario: settings.name.clone(),
            seed,
            dofs: model.dofs(),
            dt_s: settings.campaign.sampling.dt_s(),
            hit_floor: settings.campaign.hammer.floor,
            mass: rows(&model.mass),
            bare_mass: rows(&structure.bare_mass),
            sensor_masses_kg: structure.sensor_masses_kg,
            stiffness: rows(&model.stiffness),
            damping: rows(&model.damping),
            frequencies_hz: modal.frequencies_hz,
            damping_ratios: modal.damping_ratios,
            mode_shapes: modal
                .mode_shapes
                .iter()
                .map(|s| s.iter().map(|c| [c.re, c.im]).collect())
                .collect(),
            hits,
            rig: sim::rig::RigTruth::new(&settings.campaign.rig, model.dofs()),
            settings: settings.clone(),
        })
    }
}
