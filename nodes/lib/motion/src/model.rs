//! A serialisable learned model of any kind, so `fit`, `rollout` and `eval` work the same way
//! on DMP, GMR-DS, C-GMR and HMM primitives.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::cgmr::{Cgmr, CgmrConfig, Components, fit_gmr_ds};
use crate::demo::Demonstration;
use crate::dmp::{Dmp, DmpConfig};
use crate::ds::{Autonomous, FirstOrderDs, RolloutConfig, Trajectory, rollout};
use crate::error::{MotionError, Result, check_dim, invalid};
use crate::gmm::EmConfig;
use crate::gmr::GmrDs;
use crate::hmm::{HmmConfig, HmmPrimitive};

/// Which kind of model to learn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// Dynamic movement primitive (one demonstration).
    Dmp,
    /// GMR dynamical system.
    Gmr,
    /// Contracting GMR.
    Cgmr,
    /// HMM motion primitive.
    Hmm,
}

impl std::str::FromStr for ModelKind {
    type Err = MotionError;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "dmp" => Ok(Self::Dmp),
            "gmr" => Ok(Self::Gmr),
            "cgmr" => Ok(Self::Cgmr),
            "hmm" => Ok(Self::Hmm),
            other => Err(invalid(
                "model",
                format!("unknown kind `{other}` (expected dmp, gmr, cgmr or hmm)"),
            )),
        }
    }
}

/// Learning settings for every kind (each kind reads its own part).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitOptions {
    /// GMR / C-GMR: number of components or BIC range.
    pub components: Components,
    /// GMR / C-GMR: EM settings.
    pub em: EmConfig,
    /// GMR / C-GMR: keep every n-th demonstration sample for training (1 = all).
    pub subsample: usize,
    /// C-GMR extras.
    pub cgmr: CgmrConfig,
    /// DMP settings.
    pub dmp: DmpConfig,
    /// HMM settings.
    pub hmm: HmmConfig,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            components: Components::Bic(10),
            em: EmConfig::default(),
            subsample: 1,
            cgmr: CgmrConfig::default(),
            dmp: DmpConfig::default(),
            hmm: HmmConfig::default(),
        }
    }
}

/// A learned model. Reading one (from a file or from JSON in a message) checks it completely
/// ([`Model::validate`]): a model that deserialises can be run without indexing out of bounds.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", try_from = "UncheckedModel")]
pub enum Model {
    /// DMP.
    Dmp(Dmp),
    /// GMR DS.
    Gmr(GmrDs),
    /// C-GMR.
    Cgmr(Cgmr),
    /// HMM primitive.
    Hmm(HmmPrimitive),
}

/// The serialised form of [`Model`] before [`Model::validate`].
#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum UncheckedModel {
    Dmp(Dmp),
    Gmr(GmrDs),
    Cgmr(Cgmr),
    Hmm(HmmPrimitive),
}

impl TryFrom<UncheckedModel> for Model {
    type Error = MotionError;
    fn try_from(m: UncheckedModel) -> Result<Self> {
        let m = match m {
            UncheckedModel::Dmp(m) => Self::Dmp(m),
            UncheckedModel::Gmr(m) => Self::Gmr(m),
            UncheckedModel::Cgmr(m) => Self::Cgmr(m),
            UncheckedModel::Hmm(m) => Self::Hmm(m),
        };
        m.validate()?;
        Ok(m)
    }
}

impl Model {
    /// Checks every array length and value a run of the model relies on (see
    /// [`Dmp::validate`], [`GmrDs::validate`], [`Cgmr::validate`],
    /// [`HmmPrimitive::validate`]).
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::Dmp(m) => m.validate(),
            Self::Gmr(m) => m.validate(),
            Self::Cgmr(m) => m.validate(),
            Self::Hmm(m) => m.validate(),
        }
    }

    /// Learns a model of `kind` from the demonstrations.
    pub fn fit(kind: ModelKind, demos: &[Demonstration], opts: &FitOptions) -> Result<Self> {
        crate::demo::common_dim(demos)?;
        Ok(match kind {
            ModelKind::Dmp => {
                if demos.len() != 1 {
                    return Err(invalid(
                        "demos",
                        format!(
                            "a DMP learns from exactly one demonstration, got {}",
                            demos.len()
                        ),
                    ));
                }
                Self::Dmp(Dmp::fit(&demos[0], &opts.dmp)?)
            }
            ModelKind::Gmr => {
                Self::Gmr(fit_gmr_ds(demos, opts.components, &opts.em, opts.subsample.max(1))?.0)
            }
            ModelKind::Cgmr => Self::Cgmr(Cgmr::fit(
                demos,
                opts.components,
                &opts.em,
                opts.subsample.max(1),
                &opts.cgmr,
            )?),
            ModelKind::Hmm => Self::Hmm(HmmPrimitive::fit(demos, &opts.hmm)?),
        })
    }

    /// Kind name as used on the command line.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Dmp(_) => "dmp",
            Self::Gmr(_) => "gmr",
            Self::Cgmr(_) => "cgmr",
            Self::Hmm(_) => "hmm",
        }
    }

    /// State dimension.
    pub fn dim(&self) -> usize {
        match self {
            Self::Dmp(m) => m.dim,
            Self::Gmr(m) => m.dim(),
            Self::Cgmr(m) => m.dim(),
            Self::Hmm(m) => m.dim(),
        }
    }

    /// Generates a motion from `start` towards `goal` (the learned one if `None`). DS kinds are
    /// integrated with explicit Euler until within `tol`; a DMP runs its duration then until
    /// within `tol`; an HMM generates its learned duration at the step `dt` and is translated to
    /// start at `start` (the goal is then ignored).
    pub fn rollout(
        &self,
        start: &[f64],
        goal: Option<&[f64]>,
        cfg: &RolloutConfig,
    ) -> Result<Trajectory> {
        cfg.validate()?;
        check_dim("start", self.dim(), start.len())?;
        if let Some(g) = goal {
            check_dim("goal", self.dim(), g.len())?;
        }
        match self {
            Self::Dmp(m) => m.rollout(Some(start), goal, 1.0, cfg.dt, cfg.max_steps, cfg.tol),
            Self::Gmr(m) => {
                if let Some(g) = goal {
                    let moved = GmrDs {
                        gmr: m.gmr.clone(),
                        target: g.to_vec(),
                    };
                    rollout(
                        &mut Autonomous {
                            ds: &moved,
                            goal: g.to_vec(),
                        },
                        start,
                        cfg,
                    )
                } else {
                    rollout(
                        &mut Autonomous {
                            ds: m,
                            goal: m.target.clone(),
                        },
                        start,
                        cfg,
                    )
                }
            }
            Self::Cgmr(m) => rollout(&mut m.runner(goal)?, start, cfg),
            Self::Hmm(m) => m.generate(Some(start), cfg.dt),
        }
    }

    /// The velocity field `f(x)` at the given points (row-major, `dim` columns). For C-GMR the
    /// activation is taken at its equilibrium `ω = c(x)` (0 in the demonstration area, 1
    /// elsewhere). DMP and HMM are time-driven and have no such field.
    pub fn eval(&self, points: &[f64]) -> Result<Vec<f64>> {
        let n = self.dim();
        if !points.len().is_multiple_of(n) {
            return Err(MotionError::DimensionMismatch {
                what: "points vs model dimension".into(),
                expected: n,
                got: points.len() % n,
            });
        }
        let mut out = vec![0.0; points.len()];
        match self {
            Self::Gmr(m) => {
                for (x, v) in points.chunks(n).zip(out.chunks_mut(n)) {
                    m.velocity(x, v)?;
                }
            }
            Self::Cgmr(m) => {
                for (x, v) in points.chunks(n).zip(out.chunks_mut(n)) {
                    let rel: Vec<f64> = x.iter().zip(&m.ds.target).map(|(a, b)| a - b).collect();
                    let c = m.velocity_with(&rel, 0.0, v)?;
                    if c != 0.0 {
                        m.velocity_with(&rel, c, v)?;
                    }
                }
            }
            Self::Dmp(_) => {
                return Err(MotionError::Unsupported {
                    kind: "dmp",
                    operation: "eval (no autonomous velocity field)",
                });
            }
            Self::Hmm(_) => {
                return Err(MotionError::Unsupported {
                    kind: "hmm",
                    operation: "eval (no autonomous velocity field)",
                });
            }
        }
        Ok(out)
    }

    /// Writes the model as JSON, atomically and durably ([`cowork_store::write_atomic`]): a
    /// crash at any instant leaves the old file or the new one.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| MotionError::Io {
            file: path.to_path_buf(),
            source: std::io::Error::other(e),
        })?;
        cowork_store::write_atomic(path, text.as_bytes()).map_err(|source| MotionError::Io {
            file: path.to_path_buf(),
            source,
        })
    }

    /// Reads a model written by [`Model::save`]; derived terms are rebuilt and validated.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| MotionError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        serde_json::from_str(&text).map_err(|e| MotionError::Csv {
            file: path.to_path_buf(),
            row: e.line(),
            column: e.column().to_string(),
            reason: format!("invalid model JSON: {e}"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(dim: usize, n: usize) -> Demonstration {
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let pos = t
            .iter()
            .flat_map(|t| (0..dim).map(move |j| (1.0 - t) * (j + 1) as f64))
            .collect();
        Demonstration::new(dim, t, pos, None).expect("demo")
    }

    #[test]
    fn mismatched_dimensions_and_wrong_kinds_are_errors() {
        let r = Model::fit(
            ModelKind::Gmr,
            &[line(2, 50), line(3, 50)],
            &FitOptions::default(),
        );
        assert!(
            matches!(r, Err(MotionError::DimensionMismatch { .. })),
            "{r:?}"
        );
        let opts = FitOptions {
            components: Components::Fixed(2),
            ..FitOptions::default()
        };
        let m = Model::fit(ModelKind::Cgmr, &[line(2, 50)], &opts).expect("fit");
        assert!(
            m.rollout(
                &[1.0],
                None,
                &RolloutConfig {
                    dt: 0.01,
                    max_steps: 10,
                    tol: 0.0
                }
            )
            .is_err()
        );
        assert!(m.eval(&[1.0, 2.0, 3.0]).is_err());
        let dmp = Model::fit(ModelKind::Dmp, &[line(2, 50)], &FitOptions::default()).expect("dmp");
        assert!(matches!(
            dmp.eval(&[0.0, 0.0]),
            Err(MotionError::Unsupported { .. })
        ));
    }

    #[test]
    fn every_kind_round_trips_through_json() {
        let dir = std::env::temp_dir().join(format!("cowork_motion_model_{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let opts = FitOptions {
            components: Components::Fixed(2),
            hmm: HmmConfig {
                states: 4,
                ..HmmConfig::default()
            },
            ..FitOptions::default()
        };
        for kind in [
            ModelKind::Dmp,
            ModelKind::Gmr,
            ModelKind::Cgmr,
            ModelKind::Hmm,
        ] {
            let m = Model::fit(kind, &[line(2, 60)], &opts).expect("fit");
            let p = dir.join(format!("{}.json", m.kind()));
            m.save(&p).expect("save");
            let back = Model::load(&p).expect("load");
            let cfg = RolloutConfig {
                dt: 0.01,
                max_steps: 2000,
                tol: 1e-3,
            };
            let (a, b) = (
                m.rollout(&[1.0, 2.0], None, &cfg).expect("a"),
                back.rollout(&[1.0, 2.0], None, &cfg).expect("b"),
            );
            // Exact: serde_json's float_roundtrip keeps every bit.
            assert!(
                a.pos == b.pos && a.vel == b.vel && a.t == b.t,
                "{} differs after reload",
                m.kind()
            );
        }
        std::fs::write(dir.join("bad.json"), "{\"kind\": \"gmr\", \"gmr\": 3}").expect("w");
        assert!(Model::load(&dir.join("bad.json")).is_err());
    }
}
