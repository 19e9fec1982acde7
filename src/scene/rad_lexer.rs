//! Words of a Radiance scene file: whitespace-separated, `#` comments to the end of the
//! line, double- or single-quoted strings, and `!` command lines (kept whole).

use crate::error::{Error, Result};
use std::path::Path;

/// One lexical item of a Radiance scene file, with its 1-based line.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Item {
    /// A word (quotes removed).
    Word(String, usize),
    /// A `!command` line, without the `!`, split into words.
    Command(Vec<String>, usize),
}

/// Splits `text` into words and commands; `path` names the file in errors.
///
/// # Errors
/// [`Error::Input`] for an unterminated quoted string (naming its line).
pub(crate) fn lex(path: &Path, text: &str) -> Result<Vec<Item>> {
    // Files written on Windows: a `\` before CR LF continues a command too.
    let text = text.replace("\r\n", "\n");
    let mut out = Vec::new();
    let mut line = 1;
    let mut chars = text.chars().peekable();
    let mut at_line_start = true;
    while let Some(&c) = chars.peek() {
        if c == '\n' {
            chars.next();
            line += 1;
            at_line_start = true;
            continue;
        }
        if c.is_whitespace() {
            chars.next();
            continue;
        }
        if c == '#' {
            while chars.peek().is_some_and(|&c| c != '\n') {
                chars.next();
            }
            continue;
        }
        if c == '!' && at_line_start {
            chars.next();
            let start = line;
            let mut rest = String::new();
            // A backslash before the newline continues the command.
            while let Some(c) = chars.next() {
                if c == '\\' && chars.peek() == Some(&'\n') {
                    chars.next();
                    line += 1;
                    rest.push(' ');
                    continue;
                }
                if c == '\n' {
                    line += 1;
                    break;
                }
                rest.push(c);
            }
            let words = split_words(path, &rest, start)?;
            out.push(Item::Command(words, start));
            at_line_start = true;
            continue;
        }
        at_line_start = false;
        let start = line;
        let (word, closed) = take_word(&mut chars, &mut line);
        if !closed {
            return Err(Error::input(
                path,
                Some(start),
                Some(&word.chars().take(40).collect::<String>()),
                "unterminated quoted string",
            ));
        }
        out.push(Item::Word(word, start));
    }
    Ok(out)
}

/// One word up to the next whitespace, quotes (`"` or `'`) taken out and what they hold
/// kept whole; counts the newlines inside quotes into `line`. False when a quote is not
/// closed (the word then holds what was read).
fn take_word(chars: &mut std::iter::Peekable<std::str::Chars>, line: &mut usize) -> (String, bool) {
    let mut word = String::new();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            break;
        }
        chars.next();
        if c == '"' || c == '\'' {
            let mut closed = false;
            for q in chars.by_ref() {
                if q == c {
                    closed = true;
                    break;
                }
                if q == '\n' {
                    *line += 1;
                }
                word.push(q);
            }
            if !closed {
                return (word, false);
            }
        } else {
            word.push(c);
        }
    }
    (word, true)
}

/// Words of a command line, honouring quotes.
fn split_words(path: &Path, s: &str, line: usize) -> Result<Vec<String>> {
    let mut out = Vec::new();
    let mut chars = s.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
            continue;
        }
        let (word, closed) = take_word(&mut chars, &mut 0);
        if !closed {
            return Err(Error::input(
                path,
                Some(line),
                Some(s.trim()),
                "unterminated quoted string in command",
            ));
        }
        out.push(word);
    }
    Ok(out)
}
