//! The cost parameters λ = [q*, w] and which parts of them are learned.

use serde::{Deserialize, Serialize};

/// λ = [q*, w]: the most comfortable configuration and the per-joint weights (eq. 2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Lambda {
    pub q_star: Vec<f64>,
    pub w: Vec<f64>,
}

impl Lambda {
    /// Number of joints D.
    pub fn dim(&self) -> usize {
        self.q_star.len()
    }

    /// λ as one vector [q*_1 … q*_D, w_1 … w_D].
    pub fn to_vec(&self) -> Vec<f64> {
        let mut v = self.q_star.clone();
        v.extend_from_slice(&self.w);
        v
    }

    /// The name of component `c` of [q*, w] with `dim` joints, 1-based as every screen, table
    /// and message numbers joints: `q*1` … `q*D`, `w1` … `wD`.
    pub fn component_name(c: usize, dim: usize) -> String {
        if c < dim { format!("q*{}", c + 1) } else { format!("w{}", c - dim + 1) }
    }

    /// Splits a vector [q*, w] of length 2D.
    pub fn from_slice(v: &[f64]) -> Self {
        let d = v.len() / 2;
        Self { q_star: v[..d].to_vec(), w: v[d..2 * d].to_vec() }
    }
}

/// Which parts of λ are unknown and learned; the others are known from configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LearnMask {
    /// Learn q* with w known.
    QStar,
    /// Learn w with q* known.
    Weights,
    /// Learn both.
    Both,
}

impl LearnMask {
    /// Whether component `c` of λ = [q*, w] (of length 2D) is learned.
    pub fn learns(self, c: usize, dim: usize) -> bool {
        match self {
            LearnMask::QStar => c < dim,
            LearnMask::Weights => c >= dim,
            LearnMask::Both => true,
        }
    }

    /// Indices into [q*, w] of the learned components.
    pub fn components(self, dim: usize) -> Vec<usize> {
        (0..2 * dim).filter(|&c| self.learns(c, dim)).collect()
    }
}

impl std::fmt::Display for LearnMask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::QStar => "q-star",
            Self::Weights => "weights",
            Self::Both => "both",
        })
    }
}

impl std::str::FromStr for LearnMask {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "q-star" => Ok(Self::QStar),
            "weights" => Ok(Self::Weights),
            "both" => Ok(Self::Both),
            other => Err(format!("unknown learn mask '{other}': expected q-star, weights or both")),
        }
    }
}
