//! The grid that discretises λ for the entropy of eq. 6 and for the mode.

use std::collections::BTreeMap;

use super::Belief;
use crate::ergo::{Lambda, xlogx};

/// Cell widths, one per component of λ = [q*, w]; the cell of λ is floor(λ_c / width_c).
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    widths: Vec<f64>,
}

impl Grid {
    /// A grid from explicit widths (each must be positive and finite).
    pub fn new(widths: Vec<f64>) -> Option<Self> {
        widths.iter().all(|w| w.is_finite() && *w > 0.0).then_some(Self { widths })
    }

    /// `boxes` cells across each component's support (the original code used 10 or 20);
    /// a fixed component gets width 1 (it falls in one cell anyway).
    pub fn over_supports(supports: &[(f64, f64)], boxes: usize) -> Self {
        let widths = supports
            .iter()
            .map(|&(lo, hi)| if hi > lo && (hi - lo).is_finite() { (hi - lo) / boxes as f64 } else { 1.0 })
            .collect();
        Self { widths }
    }

    pub fn widths(&self) -> &[f64] {
        &self.widths
    }

    fn cell(&self, lambda: &[f64], free: &[usize]) -> Vec<i64> {
        free.iter().map(|&c| (lambda[c] / self.widths[c]).floor() as i64).collect()
    }
}

/// Every particle's grid cell, as dense ids in the cells' lexicographic order.
#[derive(Clone, Debug)]
pub struct CellIndex {
    cell_of: Vec<usize>,
    cells: usize,
}

impl CellIndex {
    pub fn new(belief: &Belief, grid: &Grid) -> Self {
        let keys: Vec<Vec<i64>> = (0..belief.len()).map(|i| grid.cell(belief.particle(i), belief.free())).collect();
        let mut ids = BTreeMap::new();
        for k in &keys {
            ids.entry(k.clone()).or_insert(0usize);
        }
        for (n, v) in ids.values_mut().enumerate() {
            *v = n;
        }
        let cell_of = keys.iter().map(|k| ids[k]).collect();
        Self { cell_of, cells: ids.len() }
    }

    /// Probability mass per cell under `weights` (normalised).
    pub(crate) fn masses(&self, weights: &[f64]) -> Vec<f64> {
        let mut m = vec![0.0; self.cells];
        for (&c, &w) in self.cell_of.iter().zip(weights) {
            m[c] += w;
        }
        m
    }

    /// −Σ P log P over cells (eq. 6 with its minus sign restored; 0 log 0 = 0).
    pub fn entropy(&self, weights: &[f64]) -> f64 {
        -self.masses(weights).into_iter().map(xlogx).sum::<f64>()
    }

    /// The weighted mean of the particles in the heaviest cell (ties: the first cell).
    pub fn mode(&self, belief: &Belief) -> Lambda {
        let masses = self.masses(belief.weights());
        let mut best = 0;
        for (c, &m) in masses.iter().enumerate() {
            if m > masses[best] {
                best = c;
            }
        }
        let s = 2 * belief.dim();
        let mut mean = vec![0.0; s];
        for i in (0..belief.len()).filter(|&i| self.cell_of[i] == best) {
            let w = belief.weights()[i] / masses[best];
            for (m, v) in mean.iter_mut().zip(belief.particle(i)) {
                *m += w * v;
            }
        }
        Lambda::from_slice(&mean)
    }
}
