//! The link check of the rendered book: every relative `href` and `src` of every page must
//! name a file of the book, and its `#fragment` an `id` (or an `<a name>`) of that page.
//! External links (`https:`, `mailto:`) are not followed: the check runs offline.

use crate::util::Result;
use html5gum::{Token, Tokenizer};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};

/// What the check looked at.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Checked {
    pub pages: usize,
    pub links: usize,
}

/// One page: its anchors and its links (with the base they resolve against).
#[derive(Debug, Default)]
struct Page {
    ids: BTreeSet<String>,
    links: Vec<String>,
    base: Option<String>,
}

/// Checks every page under `out`; an error lists each broken link.
pub fn check(out: &Path) -> Result<Checked> {
    let mut pages = BTreeMap::new();
    for file in html_files(out)? {
        let html = std::fs::read_to_string(&file)
            .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        pages.insert(file, read_page(&html));
    }
    let mut broken = Vec::new();
    let mut checked = Checked {
        pages: pages.len(),
        links: 0,
    };
    for (file, page) in &pages {
        let dir = file.parent().unwrap_or(out);
        let base = match &page.base {
            Some(b) => normalize(&dir.join(b)),
            None => dir.to_path_buf(),
        };
        for link in &page.links {
            let Some((target, fragment)) = split(link) else {
                continue;
            };
            checked.links += 1;
            let path = if target.is_empty() {
                file.clone()
            } else if target.ends_with('/') {
                normalize(&base.join(target).join("index.html"))
            } else {
                normalize(&base.join(target))
            };
            let shown = path
                .strip_prefix(out)
                .unwrap_or(&path)
                .display()
                .to_string();
            if !path.starts_with(out) || !path.is_file() {
                broken.push(format!("{}: {link}: no file {shown}", rel(out, file)));
                continue;
            }
            if fragment.is_empty() {
                continue;
            }
            let has = pages.get(&path).is_some_and(|p| p.ids.contains(&fragment));
            if !has && path.extension().is_some_and(|x| x == "html") {
                broken.push(format!(
                    "{}: {link}: no anchor #{fragment} in {shown}",
                    rel(out, file)
                ));
            }
        }
    }
    if broken.is_empty() {
        Ok(checked)
    } else {
        Err(format!(
            "{} broken links in the book ({}):\n  {}",
            broken.len(),
            out.display(),
            broken.join("\n  ")
        ))
    }
}

/// Every chapter in `src` (the book's folder of chapters, not its subfolders, which hold
/// included parts) is listed in its `SUMMARY.md`: mdbook renders only what is listed, and
/// links to a chapter left out break only in the rendered book.
pub fn check_summary(src: &Path) -> Result<usize> {
    let summary_path = src.join("SUMMARY.md");
    let summary = std::fs::read_to_string(&summary_path)
        .map_err(|e| format!("cannot read {}: {e}", summary_path.display()))?;
    let entries =
        std::fs::read_dir(src).map_err(|e| format!("cannot read {}: {e}", src.display()))?;
    let mut chapters = Vec::new();
    for entry in entries {
        let path = entry
            .map_err(|e| format!("cannot read {}: {e}", src.display()))?
            .path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_file() && name.ends_with(".md") && name != "SUMMARY.md" {
            chapters.push(name.to_string());
        }
    }
    chapters.sort();
    let missing: Vec<&String> = chapters
        .iter()
        .filter(|c| !summary.contains(&format!("]({c})")))
        .collect();
    match missing.as_slice() {
        [] => Ok(chapters.len()),
        _ => Err(format!(
            "{} chapters not in {} (mdbook leaves them out of the book): {}",
            missing.len(),
            summary_path.display(),
            missing
                .iter()
                .map(|c| c.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The relative links and images of a markdown file outside the book (the README) must name
/// files of the repository; returns how many there are.
pub fn check_markdown(file: &Path) -> Result<usize> {
    use pulldown_cmark::{Event, Parser, Tag};
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let mut count = 0;
    let mut broken = Vec::new();
    for event in Parser::new(&text) {
        let dest = match event {
            Event::Start(Tag::Link { dest_url, .. } | Tag::Image { dest_url, .. }) => dest_url,
            _ => continue,
        };
        let Some((target, _)) = split(&dest) else {
            continue;
        };
        count += 1;
        if !target.is_empty() && !dir.join(&target).exists() {
            broken.push(dest.to_string());
        }
    }
    if broken.is_empty() {
        Ok(count)
    } else {
        Err(format!(
            "{}: links to files that do not exist: {}",
            file.display(),
            broken.join(", ")
        ))
    }
}

fn rel(out: &Path, file: &Path) -> String {
    file.strip_prefix(out).unwrap_or(file).display().to_string()
}

/// The pages of the book. mdBook's 404 page resolves its links against the site's root
/// URL, which the book does not have, so it is left out.
fn html_files(out: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut dirs = vec![out.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        let entries =
            std::fs::read_dir(&dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        for entry in entries {
            let path = entry
                .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
                .path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|x| x == "html")
                && path.file_name().is_some_and(|n| n != "404.html")
            {
                files.push(path);
            }
        }
    }
    files.sort();
    Ok(files)
}

fn read_page(html: &str) -> Page {
    let mut page = Page::default();
    for token in Tokenizer::new(html).flatten() {
        let Token::StartTag(tag) = token else {
            continue;
        };
        let name = tag.name.as_slice();
        let attr = |wanted: &[u8]| {
            tag.attributes
                .iter()
                .find(|(k, _)| k.as_slice() == wanted)
                .map(|(_, v)| String::from_utf8_lossy(&v.value).into_owned())
        };
        if let Some(id) = attr(b"id") {
            page.ids.insert(id);
        }
        if name == b"a" {
            if let Some(n) = attr(b"name") {
                page.ids.insert(n);
            }
        }
        if name == b"base" {
            page.base = attr(b"href");
        }
        let link = match name {
            b"a" | b"link" => attr(b"href"),
            b"img" | b"script" | b"source" => attr(b"src"),
            _ => None,
        };
        page.links.extend(link);
    }
    page
}

/// A relative link as (path, decoded fragment); None for what is not followed (another
/// scheme, another host).
fn split(link: &str) -> Option<(String, String)> {
    let lower = link.to_ascii_lowercase();
    if lower.starts_with("//") || lower.contains(':') && !lower.starts_with('#') {
        let scheme = lower.split(':').next().unwrap_or("");
        if lower.starts_with("//") || scheme.chars().all(|c| c.is_ascii_alphanumeric()) {
            return None;
        }
    }
    let (path, fragment) = link.split_once('#').unwrap_or((link, ""));
    let path = path.split('?').next().unwrap_or("");
    Some((decode(path), decode(fragment)))
}

/// Percent-decoding of a URL part.
fn decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(b)) => {
                out.push(b);
                i += 3;
            }
            (b, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `a/b/../c` -> `a/c`, without touching the file system.
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn book(pages: &[(&str, &str)]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "xtask-links-{}-{}",
            std::process::id(),
            pages.len()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        for (name, html) in pages {
            let path = dir.join(name);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, html).unwrap();
        }
        dir
    }

    #[test]
    fn good_links_pass_and_each_broken_one_is_named() {
        let out = book(&[
            (
                "index.html",
                r##"<a href="a/b.html#two">x</a><a href="https://example.org/x">e</a>
                   <a href="#top">t</a><h1 id="top">T</h1><img src="fig/p.png">"##,
            ),
            (
                "a/b.html",
                r#"<h2 id="two">2</h2><a href="../index.html">up</a>"#,
            ),
            ("fig/p.png", ""),
        ]);
        assert_eq!(check(&out), Ok(Checked { pages: 2, links: 4 }));
        std::fs::write(
            out.join("a/b.html"),
            r#"<h2 id="two">2</h2><a href="../index.html#nope">x</a><a href="c.html">y</a>"#,
        )
        .unwrap();
        let err = check(&out).unwrap_err();
        assert!(err.contains("2 broken links"), "{err}");
        assert!(err.contains("no anchor #nope in index.html"), "{err}");
        assert!(err.contains("no file a/c.html"), "{err}");
        std::fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn a_chapter_left_out_of_the_summary_is_named() {
        let dir = std::env::temp_dir().join(format!("summary-check-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("generated")).unwrap();
        std::fs::write(dir.join("SUMMARY.md"), "- [A](a.md)\n  - [B](b.md)\n").unwrap();
        for f in ["a.md", "b.md", "generated/part.md"] {
            std::fs::write(dir.join(f), "# x\n").unwrap();
        }
        assert_eq!(check_summary(&dir), Ok(2));
        std::fs::write(dir.join("c.md"), "# c\n").unwrap();
        let err = check_summary(&dir).unwrap_err();
        assert!(err.contains("1 chapters not in"), "{err}");
        assert!(err.ends_with(": c.md"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn splits_and_decodes() {
        assert_eq!(split("https://x.org/a"), None);
        assert_eq!(split("mailto:a@b"), None);
        assert_eq!(
            split("a%20b.html?x=1#f%C3%BC"),
            Some(("a b.html".into(), "fü".into()))
        );
        assert_eq!(split("#x"), Some((String::new(), "x".into())));
        assert_eq!(
            normalize(Path::new("/a/b/../c/./d")),
            PathBuf::from("/a/c/d")
        );
    }
}
