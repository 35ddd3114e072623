//! Results across sessions: Fig. 10, the objects each condition chose, and Table I.

use std::collections::BTreeMap;

use serde::Serialize;

use super::SessionAnalysis;
use super::stats::{Wilcoxon, mean, median, quantile, standard_error, wilcoxon_signed_rank};

/// Two learned q* are "the same" when every joint differs by at most this (5°).
pub const DISTINCT_Q_STAR_TOLERANCE_DEG: f64 = 5.0;

/// Groups of learned q*: single-linkage clusters in which neighbours differ by at most
/// `tolerance` (radians) in every joint; returns the number of clusters.
pub fn distinct_q_star(q: &[Vec<f64>], tolerance: f64) -> usize {
    let n = q.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], i: usize) -> usize {
        if p[i] != i {
            let r = find(p, p[i]);
            p[i] = r;
        }
        p[i]
    }
    for i in 0..n {
        for j in i + 1..n {
            if q[i].iter().zip(&q[j]).all(|(a, b)| (a - b).abs() <= tolerance) {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                parent[a] = b;
            }
        }
    }
    (0..n).filter(|&i| find(&mut parent, i) == i).count()
}

/// Mean ± standard error of the test log-likelihood at one iteration for one condition.
#[derive(Clone, Debug, Serialize)]
pub struct CurvePoint {
    pub condition: String,
    pub iteration: usize,
    pub n: usize,
    pub mode_mean: f64,
    pub mode_se: f64,
    pub predictive_mean: f64,
    pub predictive_se: f64,
}

/// Descriptive statistics of one Likert item for one condition.
#[derive(Clone, Debug, Serialize)]
pub struct LikertSummary {
    pub item: String,
    pub statement: String,
    pub condition: String,
    pub n: usize,
    pub mean: f64,
    pub median: f64,
    pub q1: f64,
    pub q3: f64,
}

/// The signed-rank test of one item, first condition against the second.
#[derive(Clone, Debug, Serialize)]
pub struct ItemTest {
    pub item: String,
    /// Which sessions: "all", or a condition order such as "active-passive".
    pub group: String,
    /// Differences are `first − second` per participant.
    pub first: String,
    pub second: String,
    pub pairs: usize,
    pub test: Option<Wilcoxon>,
}

/// Everything across a set of sessions (all real, or all pilot).
#[derive(Clone, Debug, Serialize)]
pub struct StudySummary {
    pub sessions: usize,
    pub completed: usize,
    pub fig10: Vec<CurvePoint>,
    /// condition → distinct learned q* (see DISTINCT_Q_STAR_TOLERANCE_DEG).
    pub distinct_q_star: BTreeMap<String, usize>,
    /// condition → object → times offered in training.
    pub objects: BTreeMap<String, BTreeMap<String, usize>>,
    pub likert: Vec<LikertSummary>,
    /// condition → share of forced choices (0–1), over sessions with a choice.
    pub forced_choice: BTreeMap<String, f64>,
    pub forced_choice_n: usize,
    pub tests: Vec<ItemTest>,
}

fn order_name(a: &SessionAnalysis) -> String {
    a.runs.iter().map(|r| r.condition.as_str()).collect::<Vec<_>>().join("-")
}

/// Summarises sessions; `conditions` fixes the order of conditions (e.g. active, passive)
/// and `items` the questionnaire's items (id, statement).
pub fn summarise(sessions: &[SessionAnalysis], conditions: &[String], items: &[(String, String)]) -> StudySummary {
    let mut fig10 = Vec::new();
    let mut distinct = BTreeMap::new();
    let mut objects: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for c in conditions {
        let runs: Vec<_> = sessions.iter().flat_map(|s| s.runs.iter().filter(|r| &r.condition == c)).collect();
        let iterations = runs.iter().map(|r| r.test_ll_mode.len()).max().unwrap_or(0);
        for it in 0..iterations {
            let mode: Vec<f64> = runs.iter().filter_map(|r| r.test_ll_mode.get(it).copied()).collect();
            let pred: Vec<f64> = runs.iter().filter_map(|r| r.test_ll_predictive.get(it).copied()).collect();
            fig10.push(CurvePoint {
                condition: c.clone(),
                iteration: it,
                n: mode.len(),
                mode_mean: mean(&mode),
                mode_se: standard_error(&mode),
                predictive_mean: mean(&pred),
                predictive_se: standard_error(&pred),
            });
        }
        let learned: Vec<Vec<f64>> = runs
            .iter()
            .filter(|r| !r.learned_q_star.is_empty() && !r.trials.is_empty())
            .map(|r| r.learned_q_star.clone())
            .collect();
        distinct.insert(c.clone(), distinct_q_star(&learned, DISTINCT_Q_STAR_TOLERANCE_DEG.to_radians()));
        let counts = objects.entry(c.clone()).or_default();
        for r in &runs {
            for t in &r.trials {
                *counts.entry(t.object.clone()).or_default() += 1;
            }
        }
    }
    // Likert answers per (item, condition), and paired differences per participant.
    let answer = |s: &SessionAnalysis, item: &str, condition: &str| -> Option<f64> {
        let program = s.runs.iter().find(|r| r.condition == condition)?.program;
        s.likert.iter().find(|(p, i, _)| *p == program && i == item).map(|(_, _, v)| *v as f64)
    };
    let mut likert = Vec::new();
    let mut tests = Vec::new();
    for (item, statement) in items {
        for c in conditions {
            let v: Vec<f64> = sessions.iter().filter_map(|s| answer(s, item, c)).collect();
            likert.push(LikertSummary {
                item: item.clone(),
                statement: statement.clone(),
                condition: c.clone(),
                n: v.len(),
                mean: mean(&v),
                median: median(&v),
                q1: quantile(&v, 0.25),
                q3: quantile(&v, 0.75),
            });
        }
        if conditions.len() == 2 {
            let mut groups: Vec<String> = vec!["all".into()];
            let mut orders: Vec<String> = sessions.iter().map(order_name).collect();
            orders.sort();
            orders.dedup();
            groups.extend(orders);
            for g in groups {
                let d: Vec<f64> = sessions
                    .iter()
                    .filter(|s| g == "all" || order_name(s) == g)
                    .filter_map(|s| Some(answer(s, item, &conditions[0])? - answer(s, item, &conditions[1])?))
                    .collect();
                tests.push(ItemTest {
                    item: item.clone(),
                    group: g,
                    first: conditions[0].clone(),
                    second: conditions[1].clone(),
                    pairs: d.len(),
                    test: wilcoxon_signed_rank(&d),
                });
            }
        }
    }
    let chosen: Vec<String> = sessions
        .iter()
        .filter_map(|s| s.choice.and_then(|p| s.runs.iter().find(|r| r.program == p)).map(|r| r.condition.clone()))
        .collect();
    let forced_choice = conditions
        .iter()
        .map(|c| {
            let k = chosen.iter().filter(|x| *x == c).count();
            (c.clone(), if chosen.is_empty() { f64::NAN } else { k as f64 / chosen.len() as f64 })
        })
        .collect();
    StudySummary {
        sessions: sessions.len(),
        completed: sessions.iter().filter(|s| s.completed).count(),
        fig10,
        distinct_q_star: distinct,
        objects,
        likert,
        forced_choice,
        forced_choice_n: chosen.len(),
        tests,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distinct_learned_q_star_by_tolerance() {
        let d = 1f64.to_radians();
        let q = vec![vec![0.0, 0.0], vec![3.0 * d, 0.0], vec![6.0 * d, 0.0], vec![20.0 * d, 0.0]];
        assert_eq!(distinct_q_star(&q, 5.0 * d), 2, "chained within 5° form one group");
        assert_eq!(distinct_q_star(&q, 1.0 * d), 4);
        assert_eq!(distinct_q_star(&[], 1.0), 0);
    }
}
