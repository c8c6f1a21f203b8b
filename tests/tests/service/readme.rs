//! The documentation works (issue 37): every relative link of the README, of `docs/`, of
//! `tests/README.md` and of BENCHMARKS.md names a file that exists (and every `#anchor` of the README
//! one of its headings); every command in the README's code blocks names a program this repository
//! builds or ships; and the README's quick start per language, its commands taken literally (only the
//! library's directory and the scratch files moved to where the tests build them), moves the rope of a
//! running service.

use std::path::{Path, PathBuf};
use std::process::Command as Process;
use tests::{Service, unique_prefix};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .unwrap()
}

/// `(target, line)` of every Markdown link `](target)` outside code blocks.
fn links(text: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    let mut fence = false;
    for (n, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        let mut rest = line;
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push((after[..end].to_string(), n + 1));
            rest = &after[end..];
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, spaces to hyphens, punctuation dropped.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

#[test]
fn every_relative_link_of_the_documentation_names_a_file_that_exists() {
    let root = root();
    let mut pages: Vec<PathBuf> = vec![
        root.join("README.md"),
        root.join("BENCHMARKS.md"),
        root.join("tests/README.md"),
    ];
    for e in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        let headings: Vec<String> = text
            .lines()
            .filter(|l| l.starts_with('#'))
            .map(|l| anchor(l.trim_start_matches('#')))
            .collect();
        for (target, line) in links(&text) {
            if target.starts_with("http://") || target.starts_with("https://") {
                continue;
            }
            checked += 1;
            let (file, frag) = target.split_once('#').unwrap_or((&target, ""));
            let ok = if file.is_empty() {
                headings.iter().any(|h| h == frag)
            } else {
                page.parent().unwrap().join(file).exists()
            };
            if !ok {
                broken.push(format!("{}:{line}: {target}", page.display()));
            }
        }
    }
    assert!(checked > 20, "only {checked} links found");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The commands of the README's `sh` code blocks, continuation lines joined, comments dropped.
fn readme_commands() -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let mut blocks = Vec::new();
    let mut block: Option<Vec<String>> = None;
    let mut pending = String::new();
    for line in text.lines() {
        let t = line.trim();
        match (&mut block, t) {
            (None, "```sh") => block = Some(Vec::new()),
            (Some(b), "```") => {
                blocks.push(std::mem::take(b));
                block = None;
            }
            (Some(b), _) => {
                let code = t.split(" # ").next().unwrap().trim();
                if code.is_empty() || code.starts_with('#') {
                    continue;
                }
                if let Some(head) = code.strip_suffix('\\') {
                    pending.push_str(head);
                    continue;
                }
                pending.push_str(code);
                b.push(std::mem::take(&mut pending));
            }
            _ => {}
        }
    }
    blocks
}

#[test]
fn every_readme_command_names_a_program_the_repository_builds_or_ships() {
    let root = root();
    let bins = [
        "solver-service",
        "chainctl",
        "hand",
        "snake",
        "reach",
        "watch",
        "latency",
        "episode",
    ];
    let packages = [
        "solver-service",
        "clients",
        "tractrix-client",
        "tractrix",
        "shared",
        "tests",
    ];
    let tools = ["cc", "c++", "mcs", "mono"];
    let mut seen = 0;
    for block in readme_commands() {
        for cmd in block {
            for part in cmd.split("&&") {
                let words: Vec<&str> = part.split_whitespace().collect();
                let words: Vec<&str> = words
                    .into_iter()
                    .skip_while(|w| w.contains('=') && !w.starts_with('-'))
                    .collect();
                let Some(&program) = words.first() else {
                    continue;
                };
                seen += 1;
                match program {
                    "cargo" => {
                        if let Some(i) = words.iter().position(|w| *w == "-p") {
                            assert!(
                                packages.contains(&words[i + 1]),
                                "{cmd}: no package {}",
                                words[i + 1]
                            );
                        }
                    }
                    "bash" => assert!(root.join(words[1]).exists(), "{cmd}: no {}", words[1]),
                    p if p.starts_with("scripts/") => {
                        assert!(root.join(p).exists(), "{cmd}: no {p}")
                    }
                    p if p.starts_with("target/") => {
                        let name = Path::new(p).file_name().unwrap().to_str().unwrap();
                        assert!(
                            bins.contains(&name) || p.starts_with("target/pyenv/bin/"),
                            "{cmd}: {p} is not a binary of the workspace"
                        );
                        for w in &words[1..] {
                            if w.ends_with(".py") {
                                assert!(root.join(w).exists(), "{cmd}: no {w}");
                            }
                        }
                    }
                    p if p.starts_with("/tmp/") => {}
                    p => assert!(tools.contains(&p), "{cmd}: unknown program {p}"),
                }
            }
        }
    }
    assert!(seen >= 10, "only {seen} commands found");
}

/// The quick start per language, as the README writes it, against a running service: each program
/// prints where the head landed. The C library's directory is the tests' (`target/debug`, where
/// `scripts/test.sh` builds it) instead of `target/release`, the scratch files go to a temporary
/// directory in `target/tmp` instead of `/tmp`, and the prefix comes from `TRACTRIX_IOX_PREFIX`.
#[test]
fn the_readme_quick_start_of_every_language_moves_the_rope() {
    let root = root();
    let lib = crate::c_api::lib_dir();
    let dir = crate::c_api::program_dir();
    let svc = Service::start(&unique_prefix(), &["--no-persist", "--wait", "event"]);
    let csharp = tests::system_packages("the README's C# quick start", &["mcs", "mono"]);
    let mut ran = Vec::new();
    for block in readme_commands() {
        for cmd in block {
            let lang = if cmd.starts_with("cc ") {
                "C"
            } else if cmd.starts_with("c++ ") {
                "C++"
            } else if cmd.starts_with("mcs ") {
                "C#"
            } else if cmd.contains("examples/hello.py") {
                "Python"
            } else if cmd.contains("--example hello") {
                "Rust"
            } else {
                continue;
            };
            if lang == "C#" && !csharp {
                continue;
            }
            let cmd = cmd
                .replace("\"$PWD/target/release\"", &lib.display().to_string())
                .replace("target/release", &lib.display().to_string())
                .replace("/tmp/", &format!("{}/", dir.path().display()))
                .replace("--release", "--profile test");
            // Under the umask 022: see `c_api::compile` (iceoryx2 sets the process's umask while it
            // binds a socket; a program linked meanwhile lacked its execute bits on a loaded runner).
            let out = Process::new("sh")
                .args(["-c", &format!("umask 022; {cmd}")])
                .current_dir(&root)
                .env("TRACTRIX_IOX_PREFIX", &svc.prefix)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            if !(out.status.success() && text.contains("head at 38 5 1, 41 joints")) {
                let programs: Vec<String> = std::fs::read_dir(dir.path())
                    .map(|d| {
                        d.flatten()
                            .map(|e| crate::c_api::describe_program(&e.path()))
                            .collect()
                    })
                    .unwrap_or_default();
                panic!(
                    "{lang}: {cmd}\n{text}{}\nthe scratch directory: {programs:#?}",
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            ran.push(lang);
        }
    }
    let expected: &[&str] = if csharp {
        &["Rust", "Python", "C", "C++", "C#"]
    } else {
        &["Rust", "Python", "C", "C++"]
    };
    assert_eq!(ran, expected);
}

/// BENCHMARKS.md's summary is what its tables give (`scripts/bench-summary.py --check`): no headline
/// figure is typed by hand or left behind by a table regenerated since.
#[test]
fn the_benchmarks_summary_is_read_from_its_tables() {
    let out = Process::new("python3")
        .arg(root().join("scripts/bench-summary.py"))
        .arg("--check")
        .arg(root().join("BENCHMARKS.md"))
        .output()
        .expect("python3");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
