//! α from data: the rationality of eq. 1 estimated by maximum marginal likelihood.
//!
//! Only the handle a participant takes is observed, so a session's evidence for α is
//! p(regions | α) = Σ_i ω_i Π_t P(R_t | Q_t, λ_i, α) over the protocol's prior particles
//! (eq. 1 and 3 in their region form, λ integrated out under the prior). Every handover of
//! the session counts — both training runs and the test phase; the training offers depend on
//! earlier answers, but an adaptive design does not change the likelihood of the answers.
//! Sessions are independent people, so the pooled evidence is the sum of the sessions' log
//! evidences. The log evidence is evaluated on a log-spaced grid of α in one pass over the
//! particles; the maximiser is the vertex of the parabola through the best grid point and
//! its neighbours (in ln α), and the support interval is where the log evidence is within
//! [`SUPPORT_DROP`] of the maximum (a likelihood-ratio 95 % interval), its ends interpolated
//! linearly between grid points.

use rayon::prelude::*;
use serde::Serialize;

use rand::SeedableRng;

use crate::belief::{Belief, BeliefError, PARTICLE_CHUNK};
use std::ops::Range;

use crate::ergo::numeric::{LANES, sum_lanes};
use crate::ergo::{FeasibleSet, exp_nonpositive, log_sum_exp};
use crate::{SeededRng, derive_seed};

/// The search range of α (both ends are grid points).
pub const ALPHA_RANGE: (f64, f64) = (0.25, 256.0);
/// Grid points per doubling of α (41 over the range).
pub(crate) const GRID_PER_OCTAVE: usize = 4;
/// χ²₁(0.95) / 2: the log-evidence drop that bounds the support interval.
pub const SUPPORT_DROP: f64 = 1.920_729_410_347_062;
/// A curve whose grid values all lie within this (relative) of each other does not identify α.
const FLAT: f64 = 1e-9;

/// Prior draws of λ over which a session's evidence is integrated, unless told otherwise: the
/// data of a session pin λ down to a small part of the prior, and a Monte Carlo integral
/// with too few draws misses it and so prefers a small α (see `docs/engine.md`).
pub const EVIDENCE_PARTICLES: usize = 20_000;
/// The most draws `analyze --alpha-particles` accepts (memory ≈ 0.5 KiB per draw).
pub const MAX_EVIDENCE_PARTICLES: usize = 1_000_000;

/// Seed purpose of the evidence's prior draws (derived from the session seed).
const PURPOSE: u64 = 401;

/// What a session says about α: the regions taken in its handovers.
impl super::SessionEvidence {
    /// log p(regions | α) under the prior at every α of [`alpha_grid`], integrated over
    /// `particles` prior draws (seeded from the session, so the same for any thread count).
    ///
    /// Per particle and set the costs are computed once; per region r with minimum cost m_r,
    /// S_r(α) = Σ_{j∈r} exp(−α (C_j − m_r)) ≥ 1 (the minimum's term is 1), so
    /// log P(R | Q, λ, α) = (−α m_R + ln S_R) − logsumexp_r(−α m_r + ln S_r) never underflows.
    /// The grid doubles α every [`GRID_PER_OCTAVE`] points, so exp(−2α d) = exp(−α d)²: one
    /// exponential per configuration and base point, then squarings.
    pub(crate) fn log_evidence_curve(&self, particles: usize) -> Result<Vec<f64>, BeliefError> {
        let mut rng = SeededRng::seed_from_u64(derive_seed(self.seed, 0, PURPOSE));
        Ok(self.log_evidence_curve_over(&Belief::from_prior(&self.prior, particles, &mut rng)?))
    }

    /// [`SessionEvidence::log_evidence_curve`](super::SessionEvidence::log_evidence_curve) over given particles.
    pub(crate) fn log_evidence_curve_over(&self, prior: &Belief) -> Vec<f64> {
        let grid = alpha_grid();
        let k_max = grid.len();
        let (dim, s) = (prior.dim(), 2 * prior.dim());
        let usable: Vec<(&FeasibleSet, usize)> = self
            .handovers
            .iter()
            .filter(|h| h.set.dim() == dim && h.region < h.set.regions().len())
            .map(|h| (&h.set, h.region))
            .collect();
        let per_particle: Vec<Vec<f64>> = prior
            .particles()
            .par_chunks(PARTICLE_CHUNK * s)
            .flat_map_iter(|ps| {
                let mut costs = Vec::new();
                let mut e = Vec::new();
                let mut sums = Vec::new();
                let (grid, usable) = (&grid, &usable);
                ps.chunks_exact(s).map(move |p| {
                    let (q_star, w) = (&p[..dim], &p[dim..]);
                    let mut ll = vec![0.0; k_max];
                    for (set, taken) in usable.iter() {
                        let configs = set.configs();
                        let n = configs.len();
                        costs.clear();
                        costs.resize(n, 0.0);
                        for (d, (&qs, &wd)) in q_star.iter().zip(w).enumerate() {
                            for (c, &q) in costs.iter_mut().zip(configs.joint(d)) {
                                let t = q - qs;
                                *c += wd * t * t;
                            }
                        }
                        let regions = set.regions();
                        let minima: Vec<f64> = regions
                            .iter()
                            .map(|r| costs[r.clone()].iter().copied().fold(f64::INFINITY, f64::min))
                            .collect();
                        for (r, m) in regions.iter().zip(&minima) {
                            for c in &mut costs[r.clone()] {
                                *c -= m;
                            }
                        }
                        sums.clear();
                        sums.resize(k_max * regions.len(), 0.0);
                        e.resize(n, 0.0);
                        region_sums(&costs, regions, grid, &mut e, &mut sums);
                        let mut terms = vec![0.0; regions.len()];
                        for (k, &alpha) in grid.iter().enumerate() {
                            for (ri, t) in terms.iter_mut().enumerate() {
                                *t = -alpha * minima[ri] + sums[k * regions.len() + ri].ln();
                            }
                            ll[k] += terms[*taken] - log_sum_exp(&terms);
                        }
                    }
                    ll
                })
            })
            .collect();
        (0..k_max)
            .map(|k| {
                let terms: Vec<f64> = prior
                    .weights()
                    .iter()
                    .zip(&per_particle)
                    .map(|(w, ll)| if *w > 0.0 { w.ln() + ll[k] } else { f64::NEG_INFINITY })
                    .collect();
                log_sum_exp(&terms)
            })
            .collect()
    }
}

/// sums[k · R + r] = Σ_{j∈r} exp(−α_k d_j) for every grid α_k and region r, given each
/// configuration's cost above its region's minimum d_j ≥ 0; `e` is scratch of d's length.
fn region_sums(d: &[f64], regions: &[Range<usize>], grid: &[f64], e: &mut [f64], sums: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { region_sums_avx2(d, regions, grid, e, sums) };
        }
    }
    region_sums_body(d, regions, grid, e, sums)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn region_sums_avx2(d: &[f64], regions: &[Range<usize>], grid: &[f64], e: &mut [f64], sums: &mut [f64]) {
    region_sums_body(d, regions, grid, e, sums)
}

#[inline(always)]
fn region_sums_body(d: &[f64], regions: &[Range<usize>], grid: &[f64], e: &mut [f64], sums: &mut [f64]) {
    let k_max = grid.len();
    let nr = regions.len();
    for (base, &a) in grid.iter().enumerate().take(GRID_PER_OCTAVE) {
        for (x, &dj) in e.iter_mut().zip(d) {
            *x = exp_nonpositive(-a * dj);
        }
        let mut k = base;
        loop {
            for (ri, r) in regions.iter().enumerate() {
                sums[k * nr + ri] = sum_in_lanes(&e[r.clone()]);
            }
            k += GRID_PER_OCTAVE;
            if k >= k_max {
                break;
            }
            // exp(−2α d) = exp(−α d)².
            for x in e.iter_mut() {
                *x *= *x;
            }
        }
    }
}

/// A sum in LANES independent accumulators (so that it vectorises), added in a fixed order.
#[inline(always)]
fn sum_in_lanes(xs: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let mut chunks = xs.chunks_exact(LANES);
    for c in &mut chunks {
        for k in 0..LANES {
            acc[k] += c[k];
        }
    }
    sum_lanes(acc) + chunks.remainder().iter().sum::<f64>()
}

/// The maximum-marginal-likelihood α and its support interval.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlphaFit {
    /// The maximiser of the log evidence.
    pub alpha: f64,
    /// The support interval; an end at the search range's end is open (see `low_open`).
    pub low: f64,
    pub high: f64,
    /// The log evidence stays within [`SUPPORT_DROP`] of the maximum down to (or up to) the
    /// end of the search range, so the data do not bound α on that side.
    pub low_open: bool,
    pub high_open: bool,
    /// The maximiser is at an end of the search range (α at most / at least that).
    pub at_range_end: bool,
    pub max_log_evidence: f64,
    /// Handovers the evidence is made of.
    pub choices: usize,
    /// (α, log evidence) on the grid, for the plot.
    pub curve: Vec<(f64, f64)>,
}

impl AlphaFit {
    /// Whether `alpha` lies in the support interval (an open end reaches to 0 or ∞).
    pub fn supports(&self, alpha: f64) -> bool {
        (self.low_open || alpha >= self.low) && (self.high_open || alpha <= self.high)
    }
}

/// The grid: ALPHA_RANGE in steps of 2^(1/GRID_PER_OCTAVE).
pub fn alpha_grid() -> Vec<f64> {
    let octaves = (ALPHA_RANGE.1 / ALPHA_RANGE.0).log2();
    let n = (octaves * GRID_PER_OCTAVE as f64).round() as usize;
    (0..=n).map(|k| ALPHA_RANGE.0 * 2f64.powf(k as f64 / GRID_PER_OCTAVE as f64)).collect()
}

/// Maximises a log evidence given on [`alpha_grid`]; `None` when it does not identify α (no
/// handovers, a curve flat over the whole range, or two separate grid maxima equal, so that
/// a tie-break would pick).
pub fn fit_alpha(values: &[f64], choices: usize) -> Option<AlphaFit> {
    let grid = alpha_grid();
    if choices == 0 || values.len() != grid.len() {
        return None;
    }
    let curve: Vec<(f64, f64)> = grid.iter().copied().zip(values.iter().copied()).collect();
    let best = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let worst = values.iter().copied().fold(f64::INFINITY, f64::min);
    let tol = FLAT * best.abs().max(1.0);
    if !best.is_finite() || best - worst <= tol {
        return None;
    }
    let top: Vec<usize> = (0..values.len()).filter(|&k| values[k] >= best - tol).collect();
    if top.windows(2).any(|w| w[1] != w[0] + 1) {
        return None;
    }
    let k = top[0];
    let u: Vec<f64> = grid.iter().map(|a| a.ln()).collect();
    let at_range_end = k == 0 || k == grid.len() - 1;
    // The parabola through the best grid point and its neighbours (equal steps h in ln α).
    let (x, fx) = if at_range_end {
        (u[k], best)
    } else {
        let (fm, f0, fp) = (values[k - 1], values[k], values[k + 1]);
        let h = u[k + 1] - u[k];
        let curvature = fp - 2.0 * f0 + fm;
        if curvature < 0.0 {
            let shift = 0.5 * (fm - fp) / curvature;
            (u[k] + h * shift.clamp(-0.5, 0.5), f0 - (fp - fm).powi(2) / (8.0 * curvature))
        } else {
            (u[k], f0)
        }
    };
    let threshold = fx - SUPPORT_DROP;
    // Linear interpolation in ln α between the outermost grid point above the threshold and
    // the next one below it, walking out from the maximum.
    let crossing = |inside: usize, outside: usize| {
        let (a, b) = (values[inside], values[outside]);
        let t = if a > b { (a - threshold) / (a - b) } else { 0.5 };
        (u[inside] + t.clamp(0.0, 1.0) * (u[outside] - u[inside])).exp()
    };
    let (low, low_open) = match (0..k).rev().find(|&j| values[j] < threshold) {
        Some(j) => (crossing(j + 1, j), false),
        None => (ALPHA_RANGE.0, true),
    };
    let (high, high_open) = match (k + 1..grid.len()).find(|&j| values[j] < threshold) {
        Some(j) => (crossing(j - 1, j), false),
        None => (ALPHA_RANGE.1, true),
    };
    Some(AlphaFit {
        alpha: x.exp(),
        low: low.min(x.exp()),
        high: high.max(x.exp()),
        low_open,
        high_open,
        at_range_end,
        max_log_evidence: fx,
        choices,
        curve,
    })
}

/// One session's α.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SessionAlpha {
    pub participant: String,
    pub session_id: String,
    pub protocol_alpha: f64,
    /// None: the session's handles do not identify α (see [`fit_alpha`]).
    pub fit: Option<AlphaFit>,
    /// Whether the protocol's α lies in the session's support interval.
    pub protocol_alpha_supported: Option<bool>,
}

/// α per session and pooled over a group of sessions.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AlphaSummary {
    pub sessions: Vec<SessionAlpha>,
    pub pooled: Option<AlphaFit>,
    /// The protocols' α values (distinct, ascending) and whether each lies in the pooled
    /// support interval: one outside is flagged.
    pub protocol_alphas: Vec<(f64, Option<bool>)>,
    /// Prior draws each session's evidence was integrated over.
    pub particles: usize,
}

impl AlphaSummary {
    /// Protocol α values outside the pooled support interval.
    pub fn flagged(&self) -> Vec<f64> {
        self.protocol_alphas.iter().filter(|(_, ok)| *ok == Some(false)).map(|(a, _)| *a).collect()
    }
}

/// Fits α for every session and pooled, each session's evidence over `particles` prior draws;
/// `progress` is called after each session.
pub fn alpha_summary(
    sessions: &[&super::SessionAnalysis],
    particles: usize,
    progress: &dyn Fn(),
) -> Result<AlphaSummary, BeliefError> {
    let mut out = Vec::with_capacity(sessions.len());
    let mut pooled = vec![0.0; alpha_grid().len()];
    for s in sessions {
        let e = &s.evidence;
        let curve = e.log_evidence_curve(particles)?;
        for (p, v) in pooled.iter_mut().zip(&curve) {
            *p += v;
        }
        let fit = fit_alpha(&curve, e.handovers.len());
        progress();
        out.push(SessionAlpha {
            participant: s.start.participant.clone(),
            session_id: s.start.session_id.clone(),
            protocol_alpha: e.alpha,
            protocol_alpha_supported: fit.as_ref().map(|f| f.supports(e.alpha)),
            fit,
        });
    }
    let pooled = fit_alpha(&pooled, sessions.iter().map(|s| s.evidence.handovers.len()).sum());
    let mut alphas: Vec<f64> = sessions.iter().map(|s| s.evidence.alpha).collect();
    alphas.sort_by(f64::total_cmp);
    alphas.dedup();
    let protocol_alphas = alphas.into_iter().map(|a| (a, pooled.as_ref().map(|f| f.supports(a)))).collect();
    Ok(AlphaSummary { sessions: out, pooled, protocol_alphas, particles })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::belief::Observed;
    use crate::ergo::{ConfigSet, Lambda, Observation};

    /// −c (ln α − ln centre)² − 10 on the grid.
    fn parabola(centre: f64, curvature: f64) -> Vec<f64> {
        alpha_grid().iter().map(|a| -curvature * (a.ln() - centre.ln()).powi(2) - 10.0).collect()
    }

    #[test]
    fn the_grid_spans_the_range_in_quarter_octaves() {
        let g = alpha_grid();
        assert_eq!(g.len(), 41);
        assert!((g[0] - ALPHA_RANGE.0).abs() < 1e-12 && (g[40] - ALPHA_RANGE.1).abs() < 1e-9);
    }

    #[test]
    fn the_maximiser_and_its_support_interval_are_found_between_grid_points() {
        // In ln α the curve is a parabola, which the vertex fit recovers exactly; the
        // interval is ln 7 ± sqrt(drop / c), up to the linear interpolation.
        let fit = fit_alpha(&parabola(7.0, 3.0), 10).unwrap();
        assert!((fit.alpha - 7.0).abs() < 1e-9, "{}", fit.alpha);
        assert!((fit.max_log_evidence + 10.0).abs() < 1e-9);
        let half = (SUPPORT_DROP / 3.0).sqrt();
        assert!((fit.low / (7f64.ln() - half).exp() - 1.0).abs() < 0.02, "{}", fit.low);
        assert!((fit.high / (7f64.ln() + half).exp() - 1.0).abs() < 0.02, "{}", fit.high);
        assert!(!fit.low_open && !fit.high_open && !fit.at_range_end);
        assert!(fit.supports(7.0) && !fit.supports(30.0) && !fit.supports(1.0));
    }

    #[test]
    fn a_weakly_curved_evidence_leaves_the_interval_open() {
        let fit = fit_alpha(&parabola(7.0, 0.01), 10).unwrap();
        assert!(fit.low_open && fit.high_open);
        assert!(fit.supports(0.01) && fit.supports(1e6));
        // A maximiser beyond the range is reported at its end.
        let fit = fit_alpha(&parabola(1e4, 1.0), 10).unwrap();
        assert!(fit.at_range_end && (fit.alpha - ALPHA_RANGE.1).abs() < 1e-9);
    }

    #[test]
    fn no_estimate_without_data_or_from_a_flat_or_tied_curve() {
        assert_eq!(fit_alpha(&parabola(7.0, 1.0), 0), None);
        assert_eq!(fit_alpha(&vec![-3.0; 41], 5), None);
        // Two separate, equal peaks (at α = 1 and 16): picking one would be a tie-break.
        let two: Vec<f64> =
            alpha_grid().iter().map(|a| -((a.ln()).powi(2)).min((a.ln() - 16f64.ln()).powi(2))).collect();
        assert_eq!(fit_alpha(&two, 5), None);
    }

    #[test]
    fn the_one_pass_curve_equals_the_belief_evidence_at_every_grid_alpha() {
        // Two regions of a 2-joint set; costs large enough that plain exponentials underflow.
        let rows: Vec<[f64; 2]> = (0..12).map(|j| [j as f64 * 0.3 - 1.0, (j * j) as f64 * 0.05]).collect();
        let labels: Vec<usize> = (0..12).map(|j| usize::from(j >= 5)).collect();
        let set = FeasibleSet::with_regions(ConfigSet::from_rows(&rows).unwrap(), &labels).unwrap();
        let lambdas: Vec<Lambda> = (0..9)
            .map(|i| Lambda { q_star: vec![i as f64 * 0.4 - 2.0, 1.0 - i as f64 * 0.2], w: vec![1.0 + i as f64, 3.0] })
            .collect();
        let weights: Vec<f64> = (0..9).map(|i| 1.0 + i as f64).collect();
        let prior = Belief::from_particles(&lambdas, &weights).unwrap();
        let regions: Vec<Observation> =
            (0..2).map(|r| Observation::Region(set.regions()[r].clone().collect())).collect();
        let handovers = [0, 1, 1]
            .map(|r| super::super::Handover { set: set.clone(), region: r, observation: regions[r].clone() })
            .to_vec();
        let e = super::super::SessionEvidence {
            prior: crate::belief::Prior::new(vec![], vec![]).unwrap(),
            alpha: 5.0,
            seed: 1,
            handovers,
        };
        let curve = e.log_evidence_curve_over(&prior);
        let observed: Vec<Observed> = vec![(&set, &regions[0]), (&set, &regions[1]), (&set, &regions[1])];
        for (a, v) in alpha_grid().iter().zip(&curve) {
            let direct = prior.log_evidence(&observed, *a).unwrap();
            assert!(v.is_finite(), "α = {a}");
            assert!((v - direct).abs() <= 1e-9 * direct.abs().max(1.0), "α = {a}: {v} vs {direct}");
        }
    }
}
