//! Scenario files (TOML): the structure, its damping, the hammer campaign
//! and how it is identified and swept. The schema is documented in the
//! README; every error names the file and the field.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sim::{
    CampaignSettings, DampingSpec, Dashpot, Floor, Model, ShearFrame, SimError, Simulator, Storey,
};

/// A scenario as written in its file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name used in reports; defaults to the file stem.
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub structure: StructureSpec,
    #[serde(default = "no_damping")]
    pub damping: DampingSpec,
    #[serde(default)]
    pub dashpots: Vec<Dashpot>,
    pub campaign: CampaignSettings,
}

fn no_damping() -> DampingSpec {
    DampingSpec::None
}

/// The structure: mass and stiffness given directly, or a shear frame
/// built from geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum StructureSpec {
    /// Mass (kg) and stiffness (N/m) matrices as arrays of rows.
    Matrices {
        mass: Vec<Vec<f64>>,
        stiffness: Vec<Vec<f64>>,
    },
    /// Storeys (bottom up) and the floors they carry.
    ShearFrame {
        storeys: Vec<Storey>,
        floors: Vec<Floor>,
    },
}

/// Why a scenario cannot be used.
#[derive(Debug, Clone, PartialEq)]
pub enum ScenarioError {
    /// The file cannot be read.
    Io { path: PathBuf, message: String },
    /// Not valid TOML or not the schema (the message carries line and column).
    Parse { path: PathBuf, message: String },
    /// A field has an invalid value.
    Invalid {
        path: PathBuf,
        field: String,
        problem: String,
    },
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScenarioError::Io { path, message } => {
                write!(f, "{}: cannot read scenario: {message}", path.display())
            }
            ScenarioError::Parse { path, message } => {
                write!(f, "{}: {}", path.display(), message.trim_end())
            }
            ScenarioError::Invalid {
                path,
                field,
                problem,
            } => write!(f, "{}: {field}: {problem}", path.display()),
        }
    }
}

impl std::error::Error for ScenarioError {}

/// A scenario with the file it came from, checked and ready to simulate.
#[derive(Debug, Clone)]
pub struct LoadedScenario {
    pub path: PathBuf,
    pub scenario: Scenario,
    pub model: Model,
}

impl Scenario {
    /// Parses TOML text; `path` is used in messages and for the default name.
    pub fn parse(text: &str, path: &Path) -> Result<Scenario, ScenarioError> {
        let mut s: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        if s.name.is_empty() {
            s.name = path
                .file_stem()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        Ok(s)
    }

    /// Builds and checks the structural model (M, K, damping).
    pub fn model(&self) -> Result<Model, SimError> {
        let (mass, stiffness) = match &self.structure {
            StructureSpec::Matrices { mass, stiffness } => {
                let n = mass.len();
                if n == 0 {
                    return Err(SimError::Invalid {
                        field: "structure.mass".into(),
                        problem: "must have at least one row".into(),
                    });
                }
                (
                    sim::matrix_from_rows("structure.mass", mass, n)?,
                    sim::matrix_from_rows("structure.stiffness", stiffness, n)?,
                )
            }
            StructureSpec::ShearFrame { storeys, floors } => {
                let frame = ShearFrame {
                    storeys: storeys.clone(),
                    floors: floors.clone(),
                };
                frame.check().map_err(|e| prefix("structure.", e))?;
                (frame.mass_matrix(), frame.stiffness_matrix())
            }
        };
        let damping = sim::build_damping(&mass, &stiffness, &self.damping, &self.dashpots)?;
        Model::new(mass, stiffness, damping).map_err(|e| match e {
            SimError::NotPositiveDefinite { matrix, pivot } => SimError::Invalid {
                field: structure_field(matrix),
                problem: format!("not positive definite (Cholesky pivot {pivot} is not positive)"),
            },
            SimError::NotSymmetric {
                matrix,
                row,
                col,
                difference,
            } => SimError::Invalid {
                field: structure_field(matrix),
                problem: format!("not symmetric: entry ({row},{col}) differs from ({col},{row}) by {difference:.3e}"),
            },
            other => other,
        })
    }

    /// The simulator for this scenario's campaign.
    pub fn simulator(&self, model: Model) -> Result<Simulator, SimError> {
        Simulator::new(model, self.campaign.clone()).map_err(|e| prefix("campaign.", e))
    }
}

fn structure_field(matrix: &str) -> String {
    match matrix {
        "damping" => "damping".into(),
        m => format!("structure.{m}"),
    }
}

fn prefix(p: &str, e: SimError) -> SimError {
    match e {
        SimError::Invalid { field, problem } => SimError::Invalid {
            field: format!("{p}{field}"),
            problem,
        },
        other => other,
    }
}

impl LoadedScenario {
    /// Reads, parses and checks a scenario file.
    pub fn load(path: &Path) -> Result<LoadedScenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let scenario = Scenario::parse(&text, path)?;
        let invalid = |e: SimError| match e {
            SimError::Invalid { field, problem } => ScenarioError::Invalid {
                path: path.to_path_buf(),
                field,
                problem,
            },
            other => ScenarioError::Invalid {
                path: path.to_path_buf(),
                field: "structure".into(),
                problem: other.to_string(),
            },
        };
        let model = scenario.model().map_err(invalid)?;
        // Build the simulator once to check the campaign settings.
        scenario.simulator(model.clone()).map_err(invalid)?;
        Ok(LoadedScenario {
            path: path.to_path_buf(),
            scenario,
            model,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[structure]
kind = "matrices"
mass = [[1.0, 0.0], [0.0, 1.0]]
stiffness = [[200.0, -100.0], [-100.0, 100.0]]

[damping]
kind = "rayleigh"
alpha = 0.1
beta = 1e-4

[campaign]
hits = 2
[campaign.hammer]
floor = 1
duration_s = 0.003
peak_n = 10.0
"#;

    fn load_text(text: &str) -> Result<LoadedScenario, ScenarioError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("case.toml");
        std::fs::write(&path, text).unwrap();
        LoadedScenario::load(&path).map_err(|e| match e {
            // Report relative to the file name only, for stable messages.
            ScenarioError::Parse { message, .. } => ScenarioError::Parse {
                path: "case.toml".into(),
                message,
            },
            ScenarioError::Invalid { field, problem, .. } => ScenarioError::Invalid {
                path: "case.toml".into(),
                field,
                problem,
            },
            other => other,
        })
    }

    #[test]
    fn minimal_scenario_loads_with_defaults() {
        let s = load_text(MINIMAL).unwrap();
        assert_eq!(s.scenario.name, "case");
        assert_eq!(s.scenario.campaign.sampling.samples, 2048);
        assert_eq!(s.model.dofs(), 2);
    }

    #[test]
    fn errors_name_file_and_field() {
        let bad = MINIMAL.replace("floor = 1", "floor = 3");
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: campaign.hammer.floor: floor 3 does not exist; floors are numbered 1..=2"
        );
        let bad = MINIMAL.replace(
            "[[200.0, -100.0], [-100.0, 100.0]]",
            "[[200.0, -100.0], [-100.0]]",
        );
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: structure.stiffness[1]: has 1 entries, expected 2"
        );
        let bad = MINIMAL.replace(
            "[[200.0, -100.0], [-100.0, 100.0]]",
            "[[100.0, -200.0], [-200.0, 100.0]]",
        );
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: structure.stiffness: not positive definite (Cholesky pivot 1 is not positive)"
        );
        let bad = MINIMAL.replace("peak_n = 10.0", "peak_n = 10.0\npeak = 3");
        let msg = load_text(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 18") && msg.contains("unknown field `peak`"),
            "{msg}"
        );
        let bad = MINIMAL.replace("alpha = 0.1", "alpha = -0.1");
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: damping.alpha: must be a finite number >= 0, got -0.1"
        );
    }
}
