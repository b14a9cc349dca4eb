//! Shear frame built from geometry and materials: rigid floors on
//! laterally flexible pillars.
//!
//! Storey i (1-based) connects floor i - 1 (the ground for i = 1) to floor
//! i. Its lateral stiffness is `pillars * c * E * I / L^3` with
//! `I = width * thickness^3 / 12` (bending across the thickness, the weak
//! axis) and `c = 12` for pillars clamped at both ends, `c = 3` for clamped
//! at one end and pinned at the other. Floor masses are lumped: the floor
//! block, half of the pillars of the storeys below and above, the sensors
//! and any added mass.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, non_negative, positive};

/// How the pillars of a storey are held at their ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EndCondition {
    /// Both ends clamped: lateral stiffness 12 E I / L^3 per pillar.
    #[default]
    ClampedClamped,
    /// One end clamped, the other pinned: 3 E I / L^3 per pillar.
    ClampedPinned,
}

impl EndCondition {
    /// Coefficient `c` of `c E I / L^3`.
    pub fn coefficient(self) -> f64 {
        match self {
            EndCondition::ClampedClamped => 12.0,
            EndCondition::ClampedPinned => 3.0,
        }
    }
}

/// One storey: identical pillars between two floors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Storey {
    /// Number of pillars.
    pub pillars: u32,
    /// Pillar section size along the floor (out of the bending plane), m.
    pub pillar_width_m: f64,
    /// Pillar section size in the direction of sway (bending), m.
    pub pillar_thickness_m: f64,
    /// Free length of the pillars (storey height), m.
    pub length_m: f64,
    /// Young's modulus of the pillars, Pa.
    pub youngs_modulus_pa: f64,
    /// Density of the pillars, kg/m^3.
    pub density_kg_m3: f64,
    /// How the pillars are held at their ends.
    #[serde(default)]
    pub end_condition: EndCondition,
}

/// One floor: a rigid block plus sensors and added masses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Floor {
    /// Block length, m.
    pub block_length_m: f64,
    /// Block width, m.
    pub block_width_m: f64,
    /// Block height, m.
    pub block_height_m: f64,
    /// Block density, kg/m^3.
    pub block_density_kg_m3: f64,
    /// Mass of the sensors on the floor, kg (reported apart by
    /// [`ShearFrame::sensor_masses_kg`]).
    #[serde(default)]
    pub sensor_mass_kg: f64,
    /// Any other added mass, kg.
    #[serde(default)]
    pub added_mass_kg: f64,
}

/// An n-storey shear frame: `storeys[i]` carries `floors[i]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShearFrame {
    /// Storeys, bottom up.
    pub storeys: Vec<Storey>,
    /// Floors, bottom up.
    pub floors: Vec<Floor>,
}

impl Storey {
    /// Second moment of area of one pillar section about its weak axis, m^4.
    pub fn second_moment_m4(&self) -> f64 {
        self.pillar_width_m * self.pillar_thickness_m.powi(3) / 12.0
    }

    /// Lateral stiffness of the whole storey, N/m.
    pub fn lateral_stiffness_n_per_m(&self) -> f64 {
        f64::from(self.pillars)
            * self.end_condition.coefficient()
            * self.youngs_modulus_pa
            * self.second_moment_m4()
            / self.length_m.powi(3)
    }

    /// Mass of all pillars of the storey, kg.
    pub fn pillars_mass_kg(&self) -> f64 {
        f64::from(self.pillars)
            * self.pillar_width_m
            * self.pillar_thickness_m
            * self.length_m
            * self.density_kg_m3
    }

    fn check(&self, at: &str) -> Result<(), SimError> {
        if self.pillars == 0 {
            return Err(SimError::invalid(
                format!("{at}.pillars"),
                "must be at least 1",
            ));
        }
        positive(&format!("{at}.pillar_width_m"), self.pillar_width_m)?;
        positive(&format!("{at}.pillar_thickness_m"), self.pillar_thickness_m)?;
        positive(&format!("{at}.length_m"), self.length_m)?;
        positive(&format!("{at}.youngs_modulus_pa"), self.youngs_modulus_pa)?;
        non_negative(&format!("{at}.density_kg_m3"), self.density_kg_m3)?;
        Ok(())
    }
}

impl Floor {
    /// Mass of the floor block alone, kg.
    pub fn block_mass_kg(&self) -> f64 {
        self.block_length_m * self.block_width_m * self.block_height_m * self.block_density_kg_m3
    }

    fn check(&self, at: &str) -> Result<(), SimError> {
        positive(&format!("{at}.block_length_m"), self.block_length_m)?;
        positive(&format!("{at}.block_width_m"), self.block_width_m)?;
        positive(&format!("{at}.block_height_m"), self.block_height_m)?;
        positive(
            &format!("{at}.block_density_kg_m3"),
            self.block_density_kg_m3,
        )?;
        non_negative(&format!("{at}.sensor_mass_kg"), self.sensor_mass_kg)?;
        non_negative(&format!("{at}.added_mass_kg"), self.added_mass_kg)?;
        Ok(())
    }
}

impl ShearFrame {
    /// Checks every dimension and material value; errors name the field as
    /// `storeys[i].field` or `floors[i].field` (zero-based, as in the file).
    pub fn check(&self) -> Result<(), SimError> {
        if self.storeys.is_empty() {
            return Err(SimError::invalid(
                "storeys",
                "at least one storey is needed",
            ));
        }
        if self.storeys.len() != self.floors.len() {
            return Err(SimError::invalid(
                "floors",
                format!(
                    "{} floors given for {} storeys; each storey carries one floor",
                    self.floors.len(),
                    self.storeys.len()
                ),
            ));
        }
        for (i, s) in self.storeys.iter().enumerate() {
            s.check(&format!("storeys[{i}]"))?;
        }
        for (i, f) in self.floors.iter().enumerate() {
            f.check(&format!("floors[{i}]"))?;
        }
        Ok(())
    }

    /// Number of floors (DOFs).
    pub fn dofs(&self) -> usize {
        self.floors.len()
    }

    /// Storey lateral stiffnesses k_1 ... k_n, N/m.
    pub fn storey_stiffnesses(&self) -> Vec<f64> {
        self.storeys
            .iter()
            .map(Storey::lateral_stiffness_n_per_m)
            .collect()
    }

    /// Lumped floor masses, kg: block + half the pillars below + half the
    /// pillars above + sensors + added mass.
    pub fn floor_masses(&self) -> Vec<f64> {
        let n = self.dofs();
        (0..n)
            .map(|i| {
                let below = 0.5 * self.storeys[i].pillars_mass_kg();
                let above = if i + 1 < n {
                    0.5 * self.storeys[i + 1].pillars_mass_kg()
                } else {
                    0.0
                };
                let f = &self.floors[i];
                f.block_mass_kg() + below + above + f.sensor_mass_kg + f.added_mass_kg
            })
            .collect()
    }

    /// Lumped floor masses without the sensors, kg: block + half the
    /// pillars below + half the pillars above + added mass. Computed
    /// without the sensor term (not by subtracting it from
    /// [`ShearFrame::floor_masses`]).
    pub fn bare_floor_masses(&self) -> Vec<f64> {
        let n = self.dofs();
        (0..n)
            .map(|i| {
                let below = 0.5 * self.storeys[i].pillars_mass_kg();
                let above = if i + 1 < n {
                    0.5 * self.storeys[i + 1].pillars_mass_kg()
                } else {
                    0.0
                };
                let f = &self.floors[i];
                f.block_mass_kg() + below + above + f.added_mass_kg
            })
            .collect()
    }

    /// Sensor mass on every floor, kg.
    pub fn sensor_masses_kg(&self) -> Vec<f64> {
        self.floors.iter().map(|f| f.sensor_mass_kg).collect()
    }

    /// Diagonal lumped mass matrix.
    pub fn mass_matrix(&self) -> DMatrix<f64> {
        DMatrix::from_diagonal(&nalgebra::DVector::from_vec(self.floor_masses()))
    }

    /// Tridiagonal stiffness matrix of the storey springs.
    pub fn stiffness_matrix(&self) -> DMatrix<f64> {
        chain_matrix(&self.storey_stiffnesses())
    }
}

/// The structure of a scenario (`[structure]`): mass and stiffness given
/// directly, or a shear frame built from geometry. Sensor masses are part
/// of the truth model either way; [`StructureMatrices`] reports the mass
/// with and without them, so that a known sensor mass can be subtracted
/// from an identified one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum StructureSpec {
    /// Mass (kg) and stiffness (N/m) matrices as arrays of rows.
    Matrices {
        /// Mass matrix rows, kg: the structure without the sensors when
        /// `sensor_masses_kg` is given, everything otherwise.
        mass: Vec<Vec<f64>>,
        /// Stiffness matrix rows, N/m.
        stiffness: Vec<Vec<f64>>,
        /// Accelerometer mass on each floor (floor 1 first), kg, added to
        /// the diagonal of `mass` for the truth model. Absent: none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sensor_masses_kg: Option<Vec<f64>>,
    },
    /// Storeys (bottom up) and the floors they carry; each floor's
    /// `sensor_mass_kg` is its sensor mass.
    ShearFrame {
        /// Storeys, bottom up.
        storeys: Vec<Storey>,
        /// Floors, bottom up.
        floors: Vec<Floor>,
    },
}

/// Mass and stiffness of a [`StructureSpec`], with the sensor masses apart.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureMatrices {
    /// Mass of the structure with its sensors (the truth model's), kg.
    pub mass: DMatrix<f64>,
    /// Mass without the sensors, kg.
    pub bare_mass: DMatrix<f64>,
    /// Sensor mass on each floor, kg (zeros when none are given).
    pub sensor_masses_kg: Vec<f64>,
    /// Stiffness, N/m.
    pub stiffness: DMatrix<f64>,
}

impl StructureSpec {
    /// Number of floors (DOFs) as written.
    pub fn dofs(&self) -> usize {
        match self {
            StructureSpec::Matrices { mass, .. } => mass.len(),
            StructureSpec::ShearFrame { floors, .. } => floors.len(),
        }
    }

    /// Builds the matrices; errors name the field as `structure.…`. The
    /// loaded mass of a shear frame is [`ShearFrame::mass_matrix`] (bit for
    /// bit); for matrices without sensor masses it is `mass` as given.
    pub fn matrices(&self) -> Result<StructureMatrices, SimError> {
        match self {
            StructureSpec::Matrices {
                mass,
                stiffness,
                sensor_masses_kg,
            } => {
                let n = mass.len();
                if n == 0 {
                    return Err(SimError::invalid(
                        "structure.mass",
                        "must have at least one row",
                    ));
                }
                let bare = crate::damping::matrix_from_rows("structure.mass", mass, n)?;
                let stiffness =
                    crate::damping::matrix_from_rows("structure.stiffness", stiffness, n)?;
                let sensors = match sensor_masses_kg {
                    None => vec![0.0; n],
                    Some(s) => {
                        if s.len() != n {
                            return Err(SimError::invalid(
                                "structure.sensor_masses_kg",
                                format!("has {} entries, expected one per floor ({n})", s.len()),
                            ));
                        }
                        for (i, &m) in s.iter().enumerate() {
                            non_negative(&format!("structure.sensor_masses_kg[{i}]"), m)?;
                        }
                        s.clone()
                    }
                };
                let mut loaded = bare.clone();
                if sensor_masses_kg.is_some() {
                    for (i, m) in sensors.iter().enumerate() {
                        loaded[(i, i)] += m;
                    }
                }
                Ok(StructureMatrices {
                    mass: loaded,
                    bare_mass: bare,
                    sensor_masses_kg: sensors,
                    stiffness,
                })
            }
            StructureSpec::ShearFrame { storeys, floors } => {
                let frame = ShearFrame {
                    storeys: storeys.clone(),
                    floors: floors.clone(),
                };
                frame.check().map_err(|e| match e {
                    SimError::Invalid { field, problem } => SimError::Invalid {
                        field: format!("structure.{field}"),
                        problem,
                    },
                    other => other,
                })?;
                Ok(StructureMatrices {
                    mass: frame.mass_matrix(),
                    bare_mass: DMatrix::from_diagonal(&nalgebra::DVector::from_vec(
                        frame.bare_floor_masses(),
                    )),
                    sensor_masses_kg: frame.sensor_masses_kg(),
                    stiffness: frame.stiffness_matrix(),
                })
            }
        }
    }
}

/// Matrix of springs (or dashpots) in a chain from the ground: element i
/// connects DOF i - 1 (ground for i = 0) to DOF i.
pub fn chain_matrix(elements: &[f64]) -> DMatrix<f64> {
    let n = elements.len();
    let mut k = DMatrix::zeros(n, n);
    for (i, &ki) in elements.iter().enumerate() {
        k[(i, i)] += ki;
        if i > 0 {
            k[(i - 1, i - 1)] += ki;
            k[(i - 1, i)] -= ki;
            k[(i, i - 1)] -= ki;
        }
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Section 4 of the paper: steel pillars 1 mm x 35 mm, 300 mm (storey 1)
    /// and 350 mm (storey 2), four per storey; aluminium blocks 200 x 45 x 45 mm.
    fn paper_frame() -> ShearFrame {
        let storey = |l: f64| Storey {
            pillars: 4,
            pillar_width_m: 0.035,
            pillar_thickness_m: 0.001,
            length_m: l,
            youngs_modulus_pa: 210e9,
            density_kg_m3: 7850.0,
            end_condition: EndCondition::ClampedClamped,
        };
        let floor = Floor {
            block_length_m: 0.2,
            block_width_m: 0.045,
            block_height_m: 0.045,
            block_density_kg_m3: 2700.0,
            sensor_mass_kg: 0.005,
            added_mass_kg: 0.0,
        };
        ShearFrame {
            storeys: vec![storey(0.3), storey(0.35)],
            floors: vec![floor.clone(), floor],
        }
    }

    #[test]
    fn storey_stiffness_matches_hand_values() {
        // Hand values: I = 35 mm * (1 mm)^3 / 12 = 2.916667 mm^4 = 2.916667e-12 m^4.
        // 12 E I / L^3 = 12 * 210e9 * 2.916667e-12 / 0.3^3 = 272.2222 N/m per
        // pillar; four pillars: 1088.889 N/m. Storey 2: 0.35^3 = 0.042875 m^3
        // -> 171.4286 N/m per pillar, 685.714 N/m for four.
        let frame = paper_frame();
        let k = frame.storey_stiffnesses();
        // Only rounding of the hand values (7 digits) separates them.
        assert_relative_eq!(k[0], 1088.889, max_relative = 1e-6);
        assert_relative_eq!(k[1], 685.7143, max_relative = 1e-6);
        let mut pinned = frame.storeys[0].clone();
        pinned.end_condition = EndCondition::ClampedPinned;
        assert_relative_eq!(
            pinned.lateral_stiffness_n_per_m(),
            1088.889 / 4.0,
            max_relative = 1e-6
        );
        let kk = frame.stiffness_matrix();
        assert_eq!(kk[(0, 0)], k[0] + k[1]);
        assert_eq!(kk[(0, 1)], -k[1]);
        assert_eq!(kk[(1, 1)], k[1]);
    }

    #[test]
    fn lumped_masses_add_block_pillars_and_sensors() {
        // Block: 0.2 * 0.045 * 0.045 m^3 * 2700 kg/m^3 = 1.09350 kg.
        // Pillar (storey 1): 0.035 * 0.001 * 0.3 m^3 * 7850 = 0.0824250 kg;
        // storey 2: 0.0961625 kg. Floor 1: block + 2 * 0.082425 + 2 * 0.0961625
        // + 0.005 = 1.4556750 kg; floor 2: block + 2 * 0.0961625 + 0.005 = 1.2908250 kg.
        let m = paper_frame().floor_masses();
        assert_relative_eq!(m[0], 1.455675, max_relative = 1e-12);
        assert_relative_eq!(m[1], 1.290825, max_relative = 1e-12);
    }

    #[test]
    fn bad_geometry_names_the_field() {
        let mut frame = paper_frame();
        frame.storeys[1].length_m = -0.35;
        assert_eq!(
            frame.check().unwrap_err().to_string(),
            "storeys[1].length_m: must be a finite number > 0, got -0.35"
        );
        let mut frame = paper_frame();
        frame.floors.pop();
        assert!(
            frame
                .check()
                .unwrap_err()
                .to_string()
                .starts_with("floors: 1 floors given for 2 storeys")
        );
    }
}
