//! `analyze`'s text report: the table on stdout (sessions, Fig. 10, objects, α, Table I)
//! and `table1.md`.

use handover::analysis::{ALPHA_RANGE, AlphaFit, AlphaSummary, Analysed, SUPPORT_DROP, SessionAnalysis, StudySummary};
use handover::record::study_of;
use handover::session::program_letter;

pub(super) fn alpha_text(f: &AlphaFit) -> String {
    let low = if f.low_open { format!("≤{}", fmt_alpha(f.low)) } else { fmt_alpha(f.low) };
    let high = if f.high_open { format!("≥{}", fmt_alpha(f.high)) } else { fmt_alpha(f.high) };
    let at = if f.at_range_end { if f.alpha <= ALPHA_RANGE.0 { "≤" } else { "≥" } } else { "" };
    format!("{at}{} [{low}, {high}]", fmt_alpha(f.alpha))
}

pub(super) fn fmt_alpha(a: f64) -> String {
    if a < 10.0 { format!("{a:.2}") } else { format!("{a:.1}") }
}

fn alpha_table(a: &AlphaSummary) -> String {
    let mut o = format!(
        "\nα by maximum marginal likelihood of the handles taken (every handover, λ integrated over {} prior draws; [95 % support interval: log evidence within {SUPPORT_DROP:.2} of the maximum]):\n",
        a.particles
    );
    match &a.pooled {
        Some(f) => {
            o += &format!(
                "  pooled over {} sessions ({} handovers): α = {}\n",
                a.sessions.len(),
                f.choices,
                alpha_text(f)
            )
        }
        None => o += &format!("  pooled over {} sessions: the handles do not identify α\n", a.sessions.len()),
    }
    for (alpha, ok) in &a.protocol_alphas {
        match ok {
            Some(true) => o += &format!("  the protocol's α = {alpha} lies inside the pooled interval\n"),
            Some(false) => {
                o += &format!(
                    "  FLAG: the protocol's α = {alpha} lies outside the pooled interval: the data disagree with it\n"
                )
            }
            None => {}
        }
    }
    for s in &a.sessions {
        let fit = s.fit.as_ref().map_or("not identified".to_string(), alpha_text);
        let flag = if s.protocol_alpha_supported == Some(false) { "  (protocol α outside)" } else { "" };
        o += &format!("  {:<18} α = {fit}{flag}\n", s.participant);
    }
    o
}

/// One letter per object of the protocol, for the session lines: the first letter of its id
/// not yet taken (then of its label, then a digit), with the legend "H Bicycle handlebars".
fn object_letters(objects: &[handover::kinematics::Object]) -> Vec<(String, char, String)> {
    let mut out: Vec<(String, char, String)> = Vec::new();
    for o in objects {
        let taken = |c: &char| out.iter().any(|(_, t, _)| t == c);
        let letter =
            o.id.chars()
                .chain(o.label.chars())
                .filter(char::is_ascii_alphabetic)
                .map(|c| c.to_ascii_uppercase())
                .chain('1'..='9')
                .find(|c| !taken(c))
                .unwrap_or('?');
        out.push((o.id.clone(), letter, o.label.clone()));
    }
    out
}

pub(super) fn table(label: &str, group: &[&Analysed], s: &StudySummary, alpha: &AlphaSummary) -> String {
    let mut o = format!("\n== {label}: {} sessions ({} completed) ==\n", s.sessions, s.completed);
    let letters = group
        .first()
        .and_then(|a| study_of(&a.log).ok())
        .map_or_else(Vec::new, |st| object_letters(&st.protocol.objects));
    let letter_of = |object: &str| letters.iter().find(|(id, _, _)| id == object).map_or('?', |(_, c, _)| *c);
    o += "\nSessions:\n";
    for a in group {
        let x = &a.analysis;
        let runs: Vec<String> = x
            .runs
            .iter()
            .map(|r| {
                let objs: String = r.trials.iter().map(|t| letter_of(&t.object)).collect();
                format!(
                    "{}={} [{}] LL {}",
                    program_letter(r.program),
                    r.condition,
                    objs,
                    r.test_ll_estimate.last().map_or("—".into(), |v| format!("{v:.1}"))
                )
            })
            .collect();
        o += &format!(
            "  {:<18} {:<10} {}{}\n",
            x.start.participant,
            if x.completed {
                "completed"
            } else if handover::record::is_over(&a.log) {
                "aborted"
            } else if a.log.finished {
                "stopped"
            } else {
                "partial"
            },
            runs.join("; "),
            x.choice.map_or(String::new(), |p| format!("; prefers {}", program_letter(p)))
        );
    }
    let legend: Vec<String> = letters.iter().map(|(_, c, l)| format!("{c} {l}")).collect();
    o += &format!(
        "  (objects: {}; LL: test log-likelihood of the posterior mean after the last iteration;\n   aborted: ended for good; stopped: quit or a signal, resumable; partial: cut short by a crash, resumable)\n",
        legend.join(", ")
    );
    o += "\nFig. 10 — test-set log-likelihood of the posterior-mean estimate (mean ± s.e.) by iteration, and the paired difference per participant (mean [95 % CI], median, share of participants with first higher; two-sided Wilcoxon):\n";
    let conditions: Vec<String> = s.distinct_q_star.keys().cloned().collect();
    let iterations = s.fig10.iter().map(|p| p.iteration).max().map_or(0, |m| m + 1);
    o += &format!("  {:>9}", "iteration");
    for c in &conditions {
        o += &format!(" {:>22}", c);
    }
    if let Some(t) = s.fig10_tests.first() {
        o += &format!("  {} − {}: mean [CI], median, share higher (p)", t.first, t.second);
    }
    o += "\n";
    for it in 0..iterations {
        o += &format!("  {it:>9}");
        for c in &conditions {
            match s.fig10.iter().find(|p| &p.condition == c && p.iteration == it) {
                Some(p) => o += &format!(" {:>22}", format!("{:.1} ± {:.1}", p.estimate_mean, p.estimate_se)),
                None => o += &format!(" {:>22}", "—"),
            }
        }
        if let Some(t) = s.fig10_tests.iter().find(|t| t.iteration == it) {
            let p = t.p_value.map_or("no difference".to_string(), super::wilcoxon_p);
            let ci =
                if t.ci_low.is_finite() { format!(" [{:+.1}, {:+.1}]", t.ci_low, t.ci_high) } else { String::new() };
            o += &format!(
                "  {:+.1}{ci}, median {:+.1}, {:.0} % higher ({p}, n={})",
                t.mean_difference,
                t.median_difference,
                100.0 * t.share_first_higher,
                t.n
            );
        }
        o += "\n";
    }
    o += "\nDistinct learned q* (participants whose 90 % credible intervals are disjoint in some learned joint): ";
    o += &s.distinct_q_star.iter().map(|(c, n)| format!("{c} {n}")).collect::<Vec<_>>().join(", ");
    o += "\nObjects offered in training: ";
    o += &s
        .objects
        .iter()
        .map(|(c, m)| format!("{c}: {}", m.iter().map(|(k, v)| format!("{k} {v}")).collect::<Vec<_>>().join(", ")))
        .collect::<Vec<_>>()
        .join("; ");
    o += "\n";
    let sessions: Vec<&SessionAnalysis> = group.iter().map(|a| &a.analysis).collect();
    for line in super::by_body::lines(&sessions) {
        o += &format!("{line}\n");
    }
    if let Some(t) = handover::analysis::robot_timings(sessions.iter().flat_map(|s| &s.robot)) {
        let with_robot = sessions.iter().filter(|s| !s.robot.is_empty()).count();
        o += &format!(
            "\nRobot ({with_robot} session(s)): {} commands: {} at pose, {} failed, {} timed out, {} unanswered; {} stale \
             answer(s) logged and ignored",
            t.commands, t.at_pose, t.failed, t.timeout, t.unanswered, t.stale
        );
        if let Some([median, min, max]) = t.to_at_pose_s {
            o += &format!("; command → at_pose {median:.2} s median [{min:.2}–{max:.2}]");
        }
        o += " (per command: robot.csv)\n";
    }
    o += &alpha_table(alpha);
    o += "\nTable I — Likert (mean / median [IQR]) and forced choice:\n";
    o += &table1_markdown(s);
    o
}

pub(super) fn table1_markdown(s: &StudySummary) -> String {
    let conditions: Vec<String> = s.distinct_q_star.keys().cloned().collect();
    let mut o = String::from("| item |");
    for c in &conditions {
        o += &format!(" {c} |");
    }
    o += " Wilcoxon (all) | by order |\n|---|";
    for _ in &conditions {
        o += "---|";
    }
    o += "---|---|\n";
    let mut items: Vec<&str> = s.likert.iter().map(|l| l.item.as_str()).collect();
    items.dedup();
    for item in items {
        o += &format!("| {item} |");
        for c in &conditions {
            match s.likert.iter().find(|l| l.item == item && &l.condition == c) {
                Some(l) if l.n > 0 => {
                    o += &format!(" {:.2} / {:.1} [{:.1}–{:.1}] (n={}) |", l.mean, l.median, l.q1, l.q3, l.n)
                }
                _ => o += " — |",
            }
        }
        let fmt = |t: &handover::analysis::ItemTest| match &t.test {
            Some(w) => {
                format!("W+={} n={} p={:.3}{}", w.w_plus, w.n, w.p_value, if w.exact { "" } else { " (normal)" })
            }
            None => format!("no non-zero pairs (n={})", t.pairs),
        };
        let all = s.tests.iter().find(|t| t.item == item && t.group == "all");
        o += &format!(" {} |", all.map_or("—".into(), fmt));
        let by: Vec<String> = s
            .tests
            .iter()
            .filter(|t| t.item == item && t.group != "all")
            .map(|t| format!("{}: {}", t.group, fmt(t)))
            .collect();
        o += &format!(" {} |\n", by.join("; "));
    }
    o += &format!("| forced choice (n={}) |", s.forced_choice_n);
    for c in &conditions {
        o += &format!(" {:.0} % |", s.forced_choice.get(c).copied().unwrap_or(f64::NAN) * 100.0);
    }
    o += " | |\n";
    o += "\nWilcoxon signed-rank, two-sided, on per-participant differences (first condition − second); \
zero differences are dropped, tied |differences| get mid-ranks; p is exact (the null distribution over all sign patterns) for up to 300 pairs, else from the normal approximation.\n";
    o
}
