//! Every `cargo xtask ...` command the book and the README show, in code blocks and inline
//! code, parsed by xtask's own argument definitions: a subcommand or an option the command
//! line does not have (or a value it refuses) fails the check, naming the file and the line.

use crate::util::Result;
use clap::error::ErrorKind;
use clap::Parser;
use pulldown_cmark::{CodeBlockKind, Event, Parser as Markdown, Tag, TagEnd};
use std::path::PathBuf;

/// What invokes xtask in a shell line.
const PREFIX: &str = "cargo xtask";

/// Checks every file; returns how many commands were parsed.
pub fn check(files: &[PathBuf]) -> Result<usize> {
    let mut count = 0;
    let mut wrong = Vec::new();
    let root = crate::util::root();
    for file in files {
        let text = std::fs::read_to_string(file)
            .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        for command in commands(&text) {
            count += 1;
            if let Err(e) = parse(&command) {
                let shown = file.strip_prefix(&root).unwrap_or(file);
                wrong.push(format!("{}: `{command}`: {e}", shown.display()));
            }
        }
    }
    if wrong.is_empty() {
        Ok(count)
    } else {
        Err(format!(
            "{} commands shown in the documentation do not exist:\n  {}",
            wrong.len(),
            wrong.join("\n  ")
        ))
    }
}

/// The `cargo xtask ...` commands in the code of a markdown text, as written (from
/// `cargo xtask` to the end of the shell command: a comment, a pipe, `&&`, `;` or a
/// redirection ends it).
pub fn commands(markdown: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_shell_block = false;
    for event in Markdown::new(markdown) {
        match event {
            Event::Start(Tag::CodeBlock(kind)) => {
                // Shell lines; Rust, Python or a program's output are not.
                in_shell_block = match kind {
                    CodeBlockKind::Fenced(lang) => matches!(
                        lang.split(',').next().map(str::trim),
                        Some("" | "sh" | "bash" | "shell" | "console")
                    ),
                    CodeBlockKind::Indented => true,
                };
            }
            Event::End(TagEnd::CodeBlock) => in_shell_block = false,
            Event::Text(text) if in_shell_block => {
                for line in text.lines() {
                    out.extend(in_line(line));
                }
            }
            Event::Code(code) => out.extend(in_line(&code)),
            _ => {}
        }
    }
    out
}

fn in_line(line: &str) -> Option<String> {
    // A shell comment only mentions commands.
    let line = match line.find(" #") {
        _ if line.trim_start().starts_with('#') => return None,
        Some(comment) => &line[..comment],
        None => line,
    };
    let start = line.find(PREFIX)?;
    let rest = &line[start..];
    let end = ["|", "&&", ";", " >", " 2>"]
        .iter()
        .filter_map(|stop| rest.find(stop))
        .min()
        .unwrap_or(rest.len());
    Some(rest[..end].trim().to_string())
}

/// Parses one command with xtask's definitions; a help request counts as parsed.
fn parse(command: &str) -> std::result::Result<(), String> {
    let words = shell_words::split(command).map_err(|e| e.to_string())?;
    // "cargo xtask" is the program name clap sees.
    let args = std::iter::once(PREFIX.to_string()).chain(words.into_iter().skip(2));
    match crate::Cli::try_parse_from(args) {
        Ok(_) => Ok(()),
        // `cargo xtask` alone (a mention of the command) prints the help.
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            Ok(())
        }
        Err(e) => Err(e
            .to_string()
            .lines()
            .next()
            .unwrap_or("does not parse")
            .to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_commands_in_shell_blocks_and_inline_code() {
        let md = "Run `cargo xtask test`.\n\n```sh\nsudo cargo xtask sim --iface vb1 # a comment\n\
                  DEFMT_LOG=error cargo xtask build && ls\nls | cargo xtask esi\n```\n\n\
                  ```rust\n// cargo xtask nothing\n```\n\n```text\n$ cargo xtask build (excerpt)\n```\n\n\
                  ```sh\n# cargo xtask commented out\nls # see cargo xtask size\n```\n";
        assert_eq!(
            commands(md),
            [
                "cargo xtask test",
                "cargo xtask sim --iface vb1",
                "cargo xtask build",
                "cargo xtask esi"
            ]
        );
    }

    #[test]
    fn parses_with_the_real_definitions() {
        assert_eq!(parse("cargo xtask bench --quick --plot DIR"), Ok(()));
        assert_eq!(parse("cargo xtask sim --help"), Ok(()));
        assert!(parse("cargo xtask bench --no-such-option").is_err());
        assert!(parse("cargo xtask deploy").is_err());
        assert!(parse("cargo xtask sim --cycle-us fast").is_err());
    }
}
