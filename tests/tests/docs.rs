//! The README and the guides in `docs/`: every link resolves to a file or a
//! heading in the repository, they say what is true now (no session
//! narration, no commit hashes), the README stays a five-minute read, and
//! its headline figures are the guides' (where the tests that print them
//! hold them within 2×).

use std::fs;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// README.md and every markdown file directly in docs/.
fn documents() -> Vec<PathBuf> {
    let mut docs: Vec<PathBuf> = fs::read_dir(repo().join("docs"))
        .expect("docs/")
        .map(|e| e.expect("a docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    docs.insert(0, repo().join("README.md"));
    docs
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Text outside fenced code blocks (links and headings live there).
fn prose(text: &str) -> String {
    let mut fenced = false;
    let mut out = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces
/// as hyphens.
fn slug(heading: &str) -> String {
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

fn headings(text: &str) -> Vec<(usize, String)> {
    prose(text)
        .lines()
        .filter_map(|l| {
            let level = l.chars().take_while(|&c| c == '#').count();
            (level > 0 && l[level..].starts_with(' '))
                .then(|| (level, l[level..].trim().to_owned()))
        })
        .collect()
}

/// The targets of `[text](target)` links in a document's prose.
fn links(text: &str) -> Vec<String> {
    let prose = prose(text);
    let mut out = Vec::new();
    let mut rest = prose.as_str();
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        if let Some(end) = rest.find(')') {
            out.push(rest[..end].to_owned());
        }
    }
    out
}

#[test]
fn every_link_resolves_to_a_file_or_a_heading() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        let text = read(&doc);
        for link in links(&text) {
            if link.starts_with("http://")
                || link.starts_with("https://")
                || link.starts_with("mailto:")
            {
                continue;
            }
            checked += 1;
            let (file, anchor) = link.split_once('#').unwrap_or((&link, ""));
            let target = if file.is_empty() {
                doc.clone()
            } else {
                doc.parent().expect("a folder").join(file)
            };
            if !target.exists() {
                broken.push(format!("{}: {link}: no such file", doc.display()));
                continue;
            }
            if !anchor.is_empty() {
                let found = headings(&read(&target))
                    .iter()
                    .any(|(_, h)| slug(h) == anchor);
                if !found {
                    broken.push(format!("{}: {link}: no such heading", doc.display()));
                }
            }
        }
    }
    assert!(
        checked > 30,
        "only {checked} links found: the parser is off"
    );
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_docs_say_what_is_true_now() {
    const NARRATION: [&str; 6] = [
        "this round",
        "the round before",
        "this session",
        "after ci",
        "earlier rounds",
        "the day's host",
    ];
    let mut found = Vec::new();
    for doc in documents() {
        let text = read(&doc);
        let lower = text.to_lowercase();
        for phrase in NARRATION {
            if lower.contains(phrase) {
                found.push(format!("{}: \"{phrase}\"", doc.display()));
            }
        }
        // A commit hash: 7 to 40 hex digits with a letter and a digit, a word
        // of its own (not the mantissa of 1.0000004e-4).
        for word in text.split(|c: char| !c.is_ascii_alphanumeric() && c != '.' && c != '-') {
            let hex = word.len() >= 7
                && word.len() <= 40
                && word
                    .bytes()
                    .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase())
                && word.bytes().any(|b| b.is_ascii_digit())
                && word.bytes().any(|b| b.is_ascii_alphabetic() && b != b'e');
            if hex {
                found.push(format!("{}: {word} (a commit hash?)", doc.display()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "history belongs in git:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_readme_is_a_five_minute_read() {
    let bytes = read(&repo().join("README.md")).len();
    assert!(
        bytes <= 16_000,
        "README.md is {bytes} bytes; the guides in docs/ take the detail"
    );
}

/// The section of `text` under the heading whose anchor is `anchor`, up to
/// the next heading of the same or a higher level.
fn section<'t>(text: &'t str, anchor: &str) -> Option<&'t str> {
    let mut start = None;
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let level = line.chars().take_while(|&c| c == '#').count();
        if level > 0 && line[level..].starts_with(' ') {
            match start {
                None if slug(&line[level..]) == anchor => start = Some((offset, level)),
                Some((s, l)) if level <= l => return Some(&text[s..offset]),
                _ => {}
            }
        }
        offset += line.len();
    }
    start.map(|(s, _)| &text[s..])
}

#[test]
fn the_readme_figures_are_the_guides() {
    let readme = read(&repo().join("README.md"));
    let table = section(&readme, "figures").expect("README has a Figures section");
    let rows: Vec<Vec<&str>> = table
        .lines()
        .skip_while(|l| !l.starts_with("| figure | value | command | guide |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert!(rows.len() >= 4, "{} figure rows", rows.len());
    for row in rows {
        let [what, value, command, guide] = row[..] else {
            panic!("a figure row of {} cells: {row:?}", row.len());
        };
        assert!(
            command.starts_with('`') && command.ends_with('`'),
            "{what}: no command"
        );
        let link = links(guide)
            .pop()
            .unwrap_or_else(|| panic!("{what}: no guide link"));
        let (file, anchor) = link
            .split_once('#')
            .unwrap_or_else(|| panic!("{what}: {link} names no heading"));
        let text = read(&repo().join(file));
        let body =
            section(&text, anchor).unwrap_or_else(|| panic!("{what}: {file} has no #{anchor}"));
        assert!(
            body.contains(value),
            "{what}: README says {value}, which {file}#{anchor} does not"
        );
        let command = command.trim_matches('`');
        assert!(
            body.contains(command) || text.contains(command),
            "{what}: {file} does not name the command {command}"
        );
    }
}
