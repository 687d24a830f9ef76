//! The settings a person has to hold in their head stay few (issue 26): `splatseg config` prints
//! at most 50 keys, and the `--help` pages of all commands together list at most 90 options.
//!
//! Options are counted on every page (the root's, every subcommand's and the nested ones such as
//! `bench quality`), `-h/--help` not counted. The root's global options (`-q`, `-v`, `--strict`),
//! which clap repeats on every subcommand's page, count once, on the root's page where they are
//! defined; the test prints the count with the repeats too.

use std::process::Command;

fn help(path: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(path)
        .arg("--help")
        .env("COLUMNS", "100")
        .output()
        .expect("the splatseg binary runs");
    assert!(out.status.success(), "{path:?} --help failed");
    String::from_utf8(out.stdout).expect("utf-8 help")
}

/// The lines of a help page's `heading:` section (until the next heading).
fn section<'a>(page: &'a str, heading: &str) -> Vec<&'a str> {
    page.lines()
        .skip_while(|l| l.trim_end() != heading)
        .skip(1)
        .take_while(|l| l.is_empty() || l.starts_with(' '))
        .collect()
}

/// The long (or short) names of the options a page lists, without `--help`.
fn options(page: &str) -> Vec<String> {
    section(page, "Options:")
        .into_iter()
        .filter_map(|line| {
            let text = line.trim_start();
            let indent = line.len() - text.len();
            let is_option = (indent == 2 && text.starts_with('-')) || (indent == 6 && text.starts_with("--"));
            is_option.then(|| {
                let names = text.split([' ', '.', '<', '[']).collect::<Vec<_>>();
                let long = names.iter().find(|n| n.starts_with("--")).unwrap_or(&names[0]);
                long.trim_end_matches(',').to_string()
            })
        })
        .filter(|name| name != "--help" && name != "-h")
        .collect()
}

/// The subcommands a page lists, without `help`.
fn subcommands(page: &str) -> Vec<String> {
    section(page, "Commands:")
        .into_iter()
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|name| name != "help")
        .collect()
}

#[test]
fn the_help_pages_list_at_most_90_options() {
    let root = help(&[]);
    let globals = options(&root);
    let mut pages: Vec<(String, Vec<String>)> = vec![("splatseg".to_string(), globals.clone())];
    let mut with_repeats = globals.len();
    for command in subcommands(&root) {
        let page = help(&[&command]);
        let mut nested: Vec<Vec<String>> = vec![vec![command.clone()]];
        nested.extend(subcommands(&page).into_iter().map(|sub| vec![command.clone(), sub]));
        for path in nested {
            let args: Vec<&str> = path.iter().map(String::as_str).collect();
            let listed = options(&help(&args));
            with_repeats += listed.len();
            let own: Vec<String> = listed.into_iter().filter(|o| !globals.contains(o)).collect();
            pages.push((path.join(" "), own));
        }
    }
    assert!(pages.iter().any(|(p, _)| p == "bench quality") && pages.iter().any(|(p, _)| p == "bench scale"));
    let total: usize = pages.iter().map(|(_, o)| o.len()).sum();
    let listing: String =
        pages.iter().map(|(p, o)| format!("{:>3}  {p}: {}\n", o.len(), o.join(" "))).collect();
    println!("{listing}{total} options ({with_repeats} counting the global options on every page)");
    assert!(total <= 90, "{total} options on the help pages (at most 90):\n{listing}");
}

#[test]
fn splatseg_config_prints_at_most_50_keys() {
    let out = Command::new(env!("CARGO_BIN_EXE_splatseg")).arg("config").output().expect("runs");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    let keys: Vec<&str> =
        text.lines().filter(|l| !l.starts_with('#') && !l.starts_with('[') && l.contains(" = ")).collect();
    assert!(keys.len() <= 50, "{} keys (at most 50):\n{text}", keys.len());
    // Each key comes after its one-line meaning.
    let lines: Vec<&str> = text.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        if !line.starts_with('#') && !line.starts_with('[') && line.contains(" = ") {
            assert!(i > 0 && lines[i - 1].starts_with("# "), "`{line}` has no comment line above it");
        }
    }
}
