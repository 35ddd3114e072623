//! Results across sessions: Fig. 10, the objects each condition chose, and Table I.

use std::collections::BTreeMap;

use serde::Serialize;

use super::SessionAnalysis;
use crate::stats::{Paired, Wilcoxon, mean, median, quantile, standard_error, wilcoxon_signed_rank};

/// Groups of learned q*: two participants are "the same" when their 90 % credible intervals
/// overlap in every joint (a definition that resampling noise does not move, unlike the
/// distance between point estimates); groups are single-linkage clusters of that relation.
/// `intervals` holds each participant's (low, high) per joint; returns the number of groups.
pub fn distinct_q_star(intervals: &[(Vec<f64>, Vec<f64>)]) -> usize {
    let n = intervals.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], i: usize) -> usize {
        if p[i] != i {
            let r = find(p, p[i]);
            p[i] = r;
        }
        p[i]
    }
    let overlap = |a: &(Vec<f64>, Vec<f64>), b: &(Vec<f64>, Vec<f64>)| {
        a.0.iter().zip(&a.1).zip(b.0.iter().zip(&b.1)).all(|((alo, ahi), (blo, bhi))| alo <= bhi && blo <= ahi)
    };
    for i in 0..n {
        for j in i + 1..n {
            if overlap(&intervals[i], &intervals[j]) {
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
    pub estimate_mean: f64,
    pub estimate_se: f64,
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
    /// Paired tests of Fig. 10 per iteration (two conditions only).
    pub fig10_tests: Vec<Paired>,
    /// condition → distinct learned q* (see [`distinct_q_star`]).
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
        let iterations = runs.iter().map(|r| r.test_ll_estimate.len()).max().unwrap_or(0);
        for it in 0..iterations {
            let mode: Vec<f64> = runs.iter().filter_map(|r| r.test_ll_estimate.get(it).copied()).collect();
            let pred: Vec<f64> = runs.iter().filter_map(|r| r.test_ll_predictive.get(it).copied()).collect();
            fig10.push(CurvePoint {
                condition: c.clone(),
                iteration: it,
                n: mode.len(),
                estimate_mean: mean(&mode),
                estimate_se: standard_error(&mode),
                predictive_mean: mean(&pred),
                predictive_se: standard_error(&pred),
            });
        }
        let learned: Vec<(Vec<f64>, Vec<f64>)> = runs
            .iter()
            .filter(|r| !r.trials.is_empty())
            .filter_map(|r| r.beliefs.last())
            .map(|b| (b.ci_low.q_star.clone(), b.ci_high.q_star.clone()))
            .collect();
        distinct.insert(c.clone(), distinct_q_star(&learned));
        let counts = objects.entry(c.clone()).or_default();
        for r in &runs {
            for t in &r.trials {
                *counts.entry(t.object.clone()).or_default() += 1;
            }
        }
    }
    let mut fig10_tests = Vec::new();
    if conditions.len() == 2 {
        let ll = |s: &SessionAnalysis, c: &str, it: usize| {
            s.runs.iter().find(|r| r.condition == c).and_then(|r| r.test_ll_estimate.get(it).copied())
        };
        let iterations = fig10.iter().map(|p| p.iteration + 1).max().unwrap_or(0);
        for it in 0..iterations {
            let d: Vec<f64> =
                sessions.iter().filter_map(|s| Some(ll(s, &conditions[0], it)? - ll(s, &conditions[1], it)?)).collect();
            if d.is_empty() {
                continue;
            }
            // Fig. 10's comparison: the first condition − the second in the test
            // log-likelihood of the posterior mean, paired per participant (one group).
            fig10_tests.extend(Paired::over_groups(
                "test_log_likelihood",
                it,
                conditions[0].clone(),
                conditions[1].clone(),
                &[d],
            ));
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
        fig10_tests,
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
    fn participants_are_distinct_when_their_credible_intervals_are_disjoint() {
        let iv = |lo: f64, hi: f64| (vec![lo, 0.0], vec![hi, 1.0]);
        // [0, 2] overlaps [1, 3], which overlaps [2.5, 4]: one chain; [10, 11] stands apart.
        let q = vec![iv(0.0, 2.0), iv(1.0, 3.0), iv(2.5, 4.0), iv(10.0, 11.0)];
        assert_eq!(distinct_q_star(&q), 2);
        // Disjoint in one joint is enough.
        let a = (vec![0.0, 0.0], vec![1.0, 1.0]);
        let b = (vec![0.5, 2.0], vec![1.5, 3.0]);
        assert_eq!(distinct_q_star(&[a, b]), 2);
        assert_eq!(distinct_q_star(&[]), 0);
    }
}
