//! `ARCHITECTURE.md` tells the truth about how the crates depend on each other: its
//! ` ```text dependency-graph` block lists, one line per workspace crate, `crate -> dep, dep` — the
//! workspace crates it names under `[dependencies]` (and `[target.*.dependencies]`: what `cargo tree
//! -e normal` shows; dev- and build-dependencies are left out). This test reads the members from the
//! root `Cargo.toml`, each member's manifest, and the block, and fails naming every difference: an
//! edge one side has and the other lacks, a crate missing from the block, a line for a crate that
//! is not a member. Adding a crate or a dependency therefore means updating the block.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Crate name → the workspace crates it depends on.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// The opening fence of the block this test checks (GitHub renders it as plain text).
const BLOCK_FENCE: &str = "```text dependency-graph";

#[test]
fn the_dependency_graph_in_architecture_md_is_the_one_in_the_manifests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let from_manifests = workspace_graph(root);
    let doc = read(&root.join("ARCHITECTURE.md"));
    let from_doc = documented_graph(&doc).unwrap_or_else(|e| panic!("ARCHITECTURE.md: {e}"));
    let differences = differences(&from_doc, &from_manifests);
    assert!(
        differences.is_empty(),
        "ARCHITECTURE.md's dependency graph disagrees with the Cargo.toml files; update the block \
         that opens with {BLOCK_FENCE}:\n- {}",
        differences.join("\n- ")
    );
}

#[test]
fn every_kind_of_difference_is_named() {
    let doc = format!(
        "text\n{BLOCK_FENCE}\nsplatseg -> splatseg-a, splatseg-b\nsplatseg-a ->\nsplatseg-gone -> splatseg-a\n```\n"
    );
    let documented = documented_graph(&doc).expect("block parses");
    let actual: Graph = [
        ("splatseg", vec!["splatseg-a", "splatseg-c"]),
        ("splatseg-a", vec![]),
        ("splatseg-c", vec!["splatseg-a"]),
    ]
    .into_iter()
    .map(|(name, deps)| (name.to_string(), deps.into_iter().map(String::from).collect()))
    .collect();
    let found = differences(&documented, &actual);
    let expected = [
        "splatseg: Cargo.toml depends on splatseg-c, the block does not list it",
        "splatseg: the block lists splatseg-b, Cargo.toml does not depend on it",
        "splatseg-c: a workspace crate missing from the block",
        "splatseg-gone: in the block but not a workspace member",
    ];
    assert_eq!(found, expected);
    assert!(differences(&actual, &actual).is_empty());
}

#[test]
fn a_document_without_the_block_or_with_a_malformed_line_is_refused() {
    assert!(documented_graph("# Architecture\n").is_err());
    let unclosed = format!("{BLOCK_FENCE}\nsplatseg -> splatseg-a\n");
    assert!(documented_graph(&unclosed).is_err());
    let no_arrow = format!("{BLOCK_FENCE}\nsplatseg splatseg-a\n```\n");
    assert!(documented_graph(&no_arrow).is_err());
    let twice = format!("{BLOCK_FENCE}\nsplatseg ->\nsplatseg ->\n```\n");
    assert!(documented_graph(&twice).is_err());
}

pub(crate) fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

pub(crate) fn parse_toml(path: &Path) -> toml::Table {
    read(path).parse().unwrap_or_else(|e| panic!("cannot parse {}: {e}", path.display()))
}

/// The graph the manifests declare: members from the root `Cargo.toml`'s `[workspace] members`,
/// each member's `[package] name`, and the members among its normal dependencies.
fn workspace_graph(root: &Path) -> Graph {
    let root_manifest = parse_toml(&root.join("Cargo.toml"));
    let members = root_manifest
        .get("workspace")
        .and_then(|w| w.get("members"))
        .and_then(|m| m.as_array())
        .expect("the root Cargo.toml has [workspace] members");
    let manifests: Vec<toml::Table> = members
        .iter()
        .map(|m| {
            let dir = m.as_str().expect("a member is a path string");
            parse_toml(&root.join(dir).join("Cargo.toml"))
        })
        .collect();
    let name_of = |manifest: &toml::Table| -> String {
        manifest
            .get("package")
            .and_then(|p| p.get("name"))
            .and_then(|n| n.as_str())
            .expect("every member has [package] name")
            .to_string()
    };
    let names: BTreeSet<String> = manifests.iter().map(name_of).collect();
    manifests
        .iter()
        .map(|manifest| {
            let deps = normal_dependency_names(manifest).into_iter().filter(|d| names.contains(d)).collect();
            (name_of(manifest), deps)
        })
        .collect()
}

/// Names under `[dependencies]` and every `[target.<cfg>.dependencies]`.
fn normal_dependency_names(manifest: &toml::Table) -> BTreeSet<String> {
    let mut tables: Vec<&toml::Table> =
        manifest.get("dependencies").and_then(|d| d.as_table()).into_iter().collect();
    if let Some(targets) = manifest.get("target").and_then(|t| t.as_table()) {
        for target in targets.values() {
            tables.extend(target.get("dependencies").and_then(|d| d.as_table()));
        }
    }
    tables.into_iter().flat_map(|t| t.keys().cloned()).collect()
}

/// The graph written in the document's dependency-graph block.
fn documented_graph(doc: &str) -> Result<Graph, String> {
    let mut lines = doc.lines().skip_while(|l| l.trim() != BLOCK_FENCE);
    if lines.next().is_none() {
        return Err(format!("no block opening with {BLOCK_FENCE}"));
    }
    let mut graph = Graph::new();
    for line in lines {
        let line = line.trim();
        if line.starts_with("```") {
            return Ok(graph);
        }
        if line.is_empty() {
            continue;
        }
        let (name, deps) =
            line.split_once("->").ok_or_else(|| format!("`{line}` is not `crate -> dep, dep`"))?;
        let deps = deps.split(',').map(str::trim).filter(|d| !d.is_empty()).map(String::from).collect();
        if graph.insert(name.trim().to_string(), deps).is_some() {
            return Err(format!("{} has two lines", name.trim()));
        }
    }
    Err(format!("the block opening with {BLOCK_FENCE} is not closed"))
}

/// Every way `documented` differs from `actual`, one sentence each, in crate order.
fn differences(documented: &Graph, actual: &Graph) -> Vec<String> {
    let mut found = Vec::new();
    for (name, deps) in actual {
        let Some(listed) = documented.get(name) else {
            found.push(format!("{name}: a workspace crate missing from the block"));
            continue;
        };
        for dep in deps.difference(listed) {
            found.push(format!("{name}: Cargo.toml depends on {dep}, the block does not list it"));
        }
        for dep in listed.difference(deps) {
            found.push(format!("{name}: the block lists {dep}, Cargo.toml does not depend on it"));
        }
    }
    for name in documented.keys().filter(|n| !actual.contains_key(*n)) {
        found.push(format!("{name}: in the block but not a workspace member"));
    }
    found
}
