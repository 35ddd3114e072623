//! The object finding per height band and hand, as `dry-run` and `analyze` print it.

use handover::analysis::{SessionAnalysis, objects_by_body};

/// The object finding per height band and hand as text lines (none when every session has
/// the same band and hand: the overall shares say it all). Shared by `dry-run` and `analyze`.
pub fn lines(sessions: &[&SessionAnalysis]) -> Vec<String> {
    let rows = objects_by_body(sessions);
    let groups: std::collections::BTreeSet<(&str, &str)> = rows.iter().map(|r| (r.band.as_str(), r.hand)).collect();
    if groups.len() < 2 {
        return Vec::new();
    }
    let pct = |(m, lo, hi): (f64, f64, f64)| {
        if lo.is_finite() {
            format!("{:.0} % [{:.0}, {:.0}]", 100.0 * m, 100.0 * lo.max(0.0), 100.0 * hi.min(1.0))
        } else {
            format!("{:.0} %", 100.0 * m)
        }
    };
    // The last object's share is the rest; intervals are cut to the possible range.
    let last = rows.last().map(|r| r.object.clone()).unwrap_or_default();
    let mut out = vec![format!(
        "by body (height band in m, [low, high); dominant hand; each session one participant; 95 % interval over sessions, two-sided Wilcoxon; {last}: the rest):"
    )];
    for r in rows.iter().filter(|r| r.object != last) {
        let p = r.p_value.map_or("no difference".to_string(), super::wilcoxon_p);
        let (d, lo, hi) = r.difference;
        let diff = if lo.is_finite() {
            format!("{:+.0} [{:+.0}, {:+.0}] points", 100.0 * d, (100.0 * lo).max(-100.0), (100.0 * hi).min(100.0))
        } else {
            format!("{:+.0} points", 100.0 * d)
        };
        out.push(format!(
            "  {:<9} {:<5} n={:<3} {}: {} {}, {} {}; {} − {} {diff} ({p})",
            r.band,
            r.hand,
            r.sessions,
            r.object,
            r.first,
            pct(r.first_share),
            r.second,
            pct(r.second_share),
            r.first,
            r.second
        ));
    }
    out
}
