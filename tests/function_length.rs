//! Keeps functions short enough to read: no function in `src/` is longer than
//! [`MAX_LINES`] lines, from the line of its `fn` to the line of its closing brace (doc
//! comments and attributes not counted). A longer one is split into named steps
//! (docs/architecture.md, *Functions*).

use std::path::{Path, PathBuf};

/// The most lines a function may span.
const MAX_LINES: usize = 150;

/// A function found in a source text: its name and the lines (1-based) of its `fn` keyword
/// and of its closing brace.
#[derive(Debug, PartialEq)]
struct Function {
    name: String,
    first_line: usize,
    last_line: usize,
}

impl Function {
    fn lines(&self) -> usize {
        self.last_line - self.first_line + 1
    }
}

/// The characters of `text` that are code, each with its line: comments, string and
/// character literals are left out (a literal leaves one `"` behind, so that words on
/// either side stay apart), lifetimes are kept.
fn code_chars(text: &str) -> Vec<(char, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut line = 1;
    let mut out = Vec::with_capacity(chars.len());
    let mut i = 0;
    // Advances over `chars[i]`, counting lines.
    let step = |i: &mut usize, line: &mut usize| {
        if chars[*i] == '\n' {
            *line += 1;
        }
        *i += 1;
    };
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        let ident_before = i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_');
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    step(&mut i, &mut line);
                }
            }
        } else if c == 'r' && !ident_before && matches!(next, Some('"' | '#')) {
            // A raw string r"..." or r#"..."# (also br"..."): ends at `"` and as many `#`.
            let mut j = i + 1;
            while chars.get(j) == Some(&'#') {
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                // A raw identifier (r#type), not a string.
                out.push((c, line));
                i += 1;
                continue;
            }
            let hashes = j - i - 1;
            out.push(('"', line));
            i = j + 1;
            while i < chars.len() {
                if chars[i] == '"' && (1..=hashes).all(|k| chars.get(i + k) == Some(&'#')) {
                    i += 1 + hashes;
                    break;
                }
                step(&mut i, &mut line);
            }
        } else if c == '"' {
            out.push(('"', line));
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    i += 1;
                }
                step(&mut i, &mut line);
            }
            i += 1;
        } else if c == '\'' && next == Some('\\') {
            // An escaped character literal: '\n', '\'', '\u{feff}'.
            i += 3;
            while i < chars.len() && chars[i] != '\'' {
                i += 1;
            }
            i += 1;
        } else if c == '\'' && chars.get(i + 2) == Some(&'\'') {
            i += 3;
        } else {
            out.push((c, line));
            step(&mut i, &mut line);
        }
    }
    out
}

/// Every function with a body in `text`, in order of its `fn` keyword.
fn functions(text: &str) -> Vec<Function> {
    let code = code_chars(text);
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut found = Vec::new();
    for i in 0..code.len() {
        let keyword = code[i].0 == 'f'
            && code.get(i + 1).map(|c| c.0) == Some('n')
            && (i == 0 || !is_ident(code[i - 1].0))
            && code.get(i + 2).is_some_and(|c| c.0.is_whitespace());
        if !keyword {
            continue;
        }
        let mut j = i + 2;
        while j < code.len() && code[j].0.is_whitespace() {
            j += 1;
        }
        let name: String = code[j..]
            .iter()
            .map(|c| c.0)
            .take_while(|&c| is_ident(c))
            .collect();
        if name.is_empty() {
            continue; // a function pointer type, `fn(..)`
        }
        // The body starts at the first `{` outside the signature's brackets; a `;` there
        // first means a declaration without a body.
        let mut nesting = 0i32;
        let mut body = None;
        for (k, &(c, _)) in code.iter().enumerate().skip(j) {
            match c {
                '(' | '[' | '<' => nesting += 1,
                ')' | ']' => nesting -= 1,
                // `->` is not a closing angle bracket.
                '>' if code[k - 1].0 != '-' => nesting -= 1,
                ';' if nesting <= 0 => break,
                '{' if nesting <= 0 => {
                    body = Some(k);
                    break;
                }
                _ => {}
            }
        }
        let Some(open) = body else { continue };
        let mut depth = 0;
        for &(c, line) in &code[open..] {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        found.push(Function {
                            name,
                            first_line: code[i].1,
                            last_line: line,
                        });
                        break;
                    }
                }
                _ => {}
            }
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_function_in_src_is_longer_than_150_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    assert!(
        files.len() > 50,
        "expected the crate's sources under {src:?}"
    );
    let mut counted = 0;
    let mut long = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("a UTF-8 source file");
        for f in functions(&text) {
            counted += 1;
            if f.lines() > MAX_LINES {
                let path = file.strip_prefix(&src).unwrap_or(file).display();
                long.push(format!(
                    "src/{path}:{} {} ({} lines)",
                    f.first_line,
                    f.name,
                    f.lines()
                ));
            }
        }
    }
    assert!(
        counted > 500,
        "only {counted} functions found: the scanner is broken"
    );
    assert!(
        long.is_empty(),
        "functions longer than {MAX_LINES} lines; split them into named steps:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_scanner_spans_a_function_from_fn_to_its_closing_brace() {
    let text = "/// Doc.\n#[inline]\npub(crate) fn first<'a>(x: &'a str) -> [u8; 2] {\n    let s = \"}\";\n    let c = '}';\n    // }\n    /* } */\n    let r = r#\"}\"#;\n    [0; 2]\n}\nfn declared(x: fn(u8) -> u8);\nfn second() {}\n";
    assert_eq!(
        functions(text),
        vec![
            Function {
                name: "first".into(),
                first_line: 3,
                last_line: 10,
            },
            Function {
                name: "second".into(),
                first_line: 12,
                last_line: 12,
            },
        ]
    );
}

#[test]
fn the_scanner_finds_nested_functions_and_skips_escaped_characters() {
    let text =
        "fn outer() {\n    let q = '\\'';\n    let u = '\\u{7d}';\n    fn inner() {\n    }\n}\n";
    let found = functions(text);
    assert_eq!(
        found
            .iter()
            .map(|f| (f.name.as_str(), f.lines()))
            .collect::<Vec<_>>(),
        vec![("outer", 6), ("inner", 2)]
    );
}
