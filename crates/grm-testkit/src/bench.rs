//! What the benchmarks share: the median of a sample, the machine's load
//! average (printed beside every timed figure), and the instructions a
//! benchmark's own binary executes for some arguments under `valgrind
//! --tool=cachegrind` (load-independent, for same-binary ratios).

use std::process::Command;

/// The value after `name` in a bench's arguments (`--only mix`).
pub fn arg_value(args: &[String], name: &str) -> Option<String> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .cloned()
}

/// The median of `v` (the upper one of an even count); NaN for none.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The `q`-quantile of `v` (0.5: the median, 1: the largest), the
/// nearest rank of the sorted values; NaN for none.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize]
}

/// The 1, 5 and 15 minute load averages (`/proc/loadavg`), or an empty
/// string where there is none.
pub fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// The instructions the running benchmark executes when run again with
/// `args`, counted by `valgrind --tool=cachegrind --cache-sim=no`; `None`
/// when valgrind is missing or its summary has no count.
pub fn cachegrind_instructions(args: &[&str]) -> Option<u64> {
    let exe = std::env::current_exe().ok()?;
    let out = Command::new("valgrind")
        .args([
            "--tool=cachegrind",
            "--cache-sim=no",
            "--cachegrind-out-file=/dev/null",
        ])
        .arg(exe)
        .args(args)
        .output()
        .ok()?;
    let err = String::from_utf8_lossy(&out.stderr);
    let line = err
        .lines()
        .find(|l| l.contains("I   refs:") || l.contains("I refs:"))?;
    line.split(':').nth(1)?.trim().replace(',', "").parse().ok()
}

/// Prints each case's median time and median ratio (to the first case)
/// over the rounds, with the load average.
pub fn print_medians(
    rounds: usize,
    note: &str,
    names: &[&str],
    times: &[Vec<f64>],
    ratios: &[Vec<f64>],
) {
    println!("  {rounds} rounds, load {}", load());
    println!("  case      median ms   ratio (median of per-round, to {note})");
    for (k, name) in names.iter().enumerate() {
        println!(
            "  {name:<8} {:>10.2} {:>8.3}x",
            median(&times[k]),
            median(&ratios[k])
        );
    }
}

/// Prints each case's instructions for one unit of work, `(count(3) -
/// count(1)) / 2` (the set-up cancels out), and its ratio to the first
/// case; `count(case, n)` is the instructions of `n` units (e.g. this
/// bench's binary under [`cachegrind_instructions`]). `unit` names the
/// unit in the heading ("derivation", "run").
pub fn print_instructions<'c>(
    unit: &str,
    cases: impl IntoIterator<Item = &'c str>,
    count: impl Fn(&str, usize) -> Option<u64>,
) {
    println!("  instructions (cachegrind; one {unit} = (3 - 1) / 2 {unit}s):");
    let mut base = None;
    for case in cases {
        let (Some(a), Some(b)) = (count(case, 1), count(case, 3)) else {
            println!("  valgrind did not run");
            break;
        };
        let one = b.saturating_sub(a) as f64 / 2.0;
        let base = *base.get_or_insert(one);
        println!("  {case:<8} {:>10.2} M {:>8.3}x", one / 1e6, one / base);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn median_of_odd_even_and_none() {
        assert_eq!(super::median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(super::median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        assert!(super::median(&[]).is_nan());
    }
}
