//! `cargo xtask docs`: the manual (`docs/`, an mdBook), built and checked.
//!
//! 1. The chapters that come from the code are generated into `docs/book/generated/` (not
//!    in git), where the chapters include them: the object dictionary tables from the
//!    firmware's device description ([`od_tables`]) and the tables of every code the
//!    firmware sends, AL status codes, SDO aborts, FoE errors, mailbox errors and
//!    Emergencies, from the places in its source that send them ([`error_codes`]).
//! 2. mdBook (pinned, installed by `cargo xtask setup`) renders the book into `target/book`.
//! 3. Every link of the rendered book is followed: a page or image that does not exist, or
//!    an anchor that no element of its page has, fails the command ([`links`]); so does a
//!    link of the README to a file that is not there.
//! 4. Every `cargo xtask ...` command the book and the README show is parsed with xtask's
//!    own argument definitions: a command or option that does not exist fails the command
//!    ([`commands`]).

mod commands;
mod error_codes;
mod links;
mod od_tables;

use crate::util::{exec, root, Result};
use crate::{build, setup};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The book's folder (its `book.toml`), relative to the project root.
const BOOK: &str = "docs";
/// Where the generated chapters go, relative to the project root (ignored by git).
const GENERATED: &str = "docs/book/generated";

pub fn run() -> Result {
    setup::mdbook()?;
    let root = root();
    links::check_summary(&root.join(BOOK).join("book"))?;
    generate(&root.join(GENERATED))?;
    let out = build::target_dir().join("book");
    exec(
        Command::new("mdbook")
            .arg("build")
            .arg(root.join(BOOK))
            .arg("--dest-dir")
            .arg(&out),
    )?;
    let mut checked = links::check(&out)?;
    checked.links += links::check_markdown(&root.join("README.md"))?;
    let sources = markdown_sources(&root)?;
    let shown = commands::check(&sources)?;
    println!(
        "book: {} ({} pages, {} links and anchors followed, {} cargo xtask commands parsed)",
        out.join("index.html").display(),
        checked.pages,
        checked.links,
        shown
    );
    Ok(())
}

/// Writes the generated chapters into `dir`.
fn generate(dir: &Path) -> Result {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    write(
        "object-dictionary.md",
        od_tables::markdown_of_products(&firmware::products::PRODUCTS),
    )?;
    write("error-codes.md", error_codes::markdown(&root())?)?;
    Ok(())
}

/// The markdown files whose commands are checked: the README and every chapter.
fn markdown_sources(root: &Path) -> Result<Vec<PathBuf>> {
    let mut files = vec![root.join("README.md")];
    let mut dirs = vec![root.join(BOOK).join("book")];
    while let Some(dir) = dirs.pop() {
        let entries =
            std::fs::read_dir(&dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        for entry in entries {
            let path = entry
                .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
                .path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|x| x == "md") {
                files.push(path);
            }
        }
    }
    files.sort();
    Ok(files)
}
