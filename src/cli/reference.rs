//! The command-line reference in Markdown (`handover man --format markdown`), generated from
//! the same clap definition as the parser, the manual page and the completions, so that
//! `docs/reference.md` cannot drift from what the program accepts.

use std::fmt::Write as _;

use clap::Command;

/// Every command and flag of `cmd`, as Markdown.
pub fn markdown(cmd: &Command) -> String {
    // Built, every argument knows how many values it takes.
    let mut cmd = cmd.clone();
    cmd.build();
    let cmd = &cmd;
    let mut out = String::new();
    let version = cmd.get_version().unwrap_or_default();
    let _ = writeln!(out, "# Command-line reference\n");
    let _ = writeln!(
        out,
        "Generated from the command-line definition of handover {version} by `handover man --format markdown`; \
         a test fails when this file differs from what the program prints. The same text is in \
         `handover <command> --help`.\n"
    );
    if let Some(about) = cmd.get_about() {
        let _ = writeln!(out, "{about}\n");
    }
    let _ = writeln!(out, "## Commands\n");
    for sub in visible(cmd) {
        let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
        let anchor = format!("handover-{}", sub.get_name());
        let _ = writeln!(out, "- [`handover {}`](#{anchor}) — {}", sub.get_name(), first_line(&about));
    }
    out.push('\n');
    for sub in visible(cmd) {
        section(&mut out, sub, &format!("handover {}", sub.get_name()), 2);
    }
    vocabulary(&mut out);
    out
}

/// The vocabulary: each flag's one meaning and default, and where a command differs.
fn vocabulary(out: &mut String) {
    use super::vocabulary::{CONCEPTS, RENAMED};
    let _ = writeln!(
        out,
        "## Flags across commands\n\nA flag means the same in every command that takes it; a command that sweeps a \
         setting takes a comma-separated list under the same flag. Defaults are the same everywhere except where \
         said.\n"
    );
    let _ = writeln!(out, "| flag | meaning | default |\n|---|---|---|");
    let mut concepts: Vec<_> = CONCEPTS.iter().collect();
    concepts.sort_by_key(|c| c.flag);
    for c in concepts {
        let mut default = c.default.map_or("—".to_string(), |d| format!("`{d}`"));
        for e in c.except {
            let theirs = e.default.map_or("none".to_string(), |d| format!("`{d}`"));
            default.push_str(&format!("; `{}`: {theirs} ({})", e.command, e.why));
        }
        let value = if c.value.is_empty() { String::new() } else { format!(" {}", c.value) };
        let _ = writeln!(out, "| `--{}{value}` | {} | {} |", c.flag, cell(c.meaning), cell(&default));
    }
    let _ = writeln!(out, "\n### Renamed in 0.2.0\n\nThe old spellings work, with a warning, until 0.4.0.\n");
    let _ = writeln!(out, "| old | new |\n|---|---|");
    for r in RENAMED {
        let command = if r.command.is_empty() { String::new() } else { format!("{} ", r.command) };
        let _ = writeln!(out, "| `handover {command}{}` | `handover {command}{}` |", r.old, r.new);
    }
}

fn visible(cmd: &Command) -> impl Iterator<Item = &Command> {
    cmd.get_subcommands().filter(|s| !s.is_hide_set() && s.get_name() != "help")
}

fn first_line(text: &str) -> &str {
    text.lines().next().unwrap_or_default()
}

fn section(out: &mut String, cmd: &Command, path: &str, depth: usize) {
    let hashes = "#".repeat(depth + 1);
    let _ = writeln!(out, "{hashes} `{path}`\n");
    let about = cmd.get_long_about().or(cmd.get_about()).map(|a| a.to_string()).unwrap_or_default();
    if !about.is_empty() {
        let _ = writeln!(out, "{}\n", about.trim_end());
    }
    let mut usage = cmd.clone().bin_name(path.to_string());
    let usage = usage.render_usage().to_string();
    let usage = usage.trim_start_matches("Usage: ");
    let _ = writeln!(out, "```text\n{usage}\n```\n");
    let args: Vec<&clap::Arg> =
        cmd.get_arguments().filter(|a| !a.is_hide_set() && a.get_id() != "help" && a.get_id() != "version").collect();
    if !args.is_empty() {
        let _ = writeln!(out, "| argument | meaning |\n|---|---|");
        for a in args {
            let _ = writeln!(out, "| {} | {} |", cell(&name(a)), cell(&meaning(a)));
        }
        out.push('\n');
    }
    for sub in visible(cmd) {
        section(out, sub, &format!("{path} {}", sub.get_name()), depth + 1);
    }
}

/// How an argument is written: `--flag VALUE`, `-s, --flag`, or `<VALUE>` for a positional.
fn name(a: &clap::Arg) -> String {
    let values: Vec<String> = a
        .get_value_names()
        .map_or_else(|| vec![a.get_id().as_str().to_uppercase()], |v| v.iter().map(|s| s.to_string()).collect());
    let takes_value = a.get_num_args().is_some_and(|n| n.takes_values());
    if a.is_positional() {
        return format!("`<{}>`", values.join(" "));
    }
    let mut s = String::new();
    if let Some(short) = a.get_short() {
        s.push_str(&format!("-{short}, "));
    }
    if let Some(long) = a.get_long() {
        s.push_str(&format!("--{long}"));
    }
    if takes_value {
        s.push_str(&format!(" {}", values.join(" ")));
    }
    format!("`{s}`")
}

/// Its help, its possible values and its default.
fn meaning(a: &clap::Arg) -> String {
    let mut s = a.get_long_help().or(a.get_help()).map(|h| h.to_string()).unwrap_or_default();
    s = s.trim_end().to_string();
    if !s.is_empty() && !s.ends_with('.') {
        s.push('.');
    }
    let possible: Vec<String> =
        a.get_possible_values().iter().filter(|v| !v.is_hide_set()).map(|v| format!("`{}`", v.get_name())).collect();
    if !possible.is_empty() && a.get_num_args().is_some_and(|n| n.takes_values()) {
        s.push_str(&format!(" One of {}.", possible.join(", ")));
    }
    let defaults: Vec<String> = a.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
    if !defaults.is_empty() && a.get_num_args().is_some_and(|n| n.takes_values()) {
        s.push_str(&format!(" Default: `{}`.", defaults.join(",")));
    }
    if let Some(env) = a.get_env() {
        s.push_str(&format!(" Environment: `{}`.", env.to_string_lossy()));
    }
    if a.is_required_set() {
        s.push_str(" Required.");
    }
    s
}

/// A text as one table cell: one line, pipes escaped.
fn cell(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ").replace('|', "\\|")
}
