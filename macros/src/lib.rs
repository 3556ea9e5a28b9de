//! The token rewriting behind `reckon::model!`: every float literal that is the left
//! operand of a binary `+ - * /` becomes `$crate::__private::Lhs(literal)`, so that
//! `2.0 * x[0]` compiles when `x[0]` is a dual number (no crate but num-dual may
//! implement `f64 × dual`, so the literal is wrapped in a reckon type that can).
//!
//! No `syn`: the body is walked as plain tokens. A literal is a left operand when the
//! next operator is `+ - * /` and the operator before it does not bind it tighter:
//!
//! | before the literal | next `+`/`-` | next `*`/`/` |
//! |---|---|---|
//! | start, `(`, `,`, `;`, `=`, `{…}`, `=>`, comparison, `&&`, `\|\|`, `return`… | wrap | wrap |
//! | binary `+`/`-` | (right operand) | wrap |
//! | `*`, `/`, `%`, `.`, unary `-`/`!`/`&`, `as`, a name | leave | leave |
//!
//! A unary minus is part of the literal (`-2.0 * x` → `Lhs(-2.0) * x`, Rust's
//! `(-2.0) * x`). Integer literals (`2 * n`) and a literal followed by `.`
//! (`2.0f64.sqrt()`) are left alone; so are `f32` literals (`Lhs` holds an `f64`)
//! and `const`/`static` items (const contexts, where `Lhs`'s operators cannot run).

use proc_macro::{Delimiter, Group, Ident, Literal, Punct, Spacing, Span, TokenStream, TokenTree};

/// `lift_literals!($crate, body)`: `body` with every float literal that is the left
/// operand of `+ - * /` wrapped as `$crate::__private::Lhs(literal)`.
#[proc_macro]
pub fn lift_literals(input: TokenStream) -> TokenStream {
    let mut it = input.into_iter();
    let krate = match it.next() {
        Some(t @ TokenTree::Ident(_)) => t,
        _ => return error("lift_literals!: expected `$crate, body`"),
    };
    match it.next() {
        Some(TokenTree::Punct(p)) if p.as_char() == ',' => {}
        _ => return error("lift_literals!: expected `$crate, body`"),
    }
    rewrite(it.collect(), &krate, true)
}

fn error(msg: &str) -> TokenStream {
    let lit = TokenTree::Literal(Literal::string(msg));
    let body = TokenTree::Group(Group::new(Delimiter::Parenthesis, lit.into()));
    [
        TokenTree::Punct(Punct::new(':', Spacing::Joint)),
        TokenTree::Punct(Punct::new(':', Spacing::Alone)),
        TokenTree::Ident(Ident::new("core", Span::call_site())),
        TokenTree::Punct(Punct::new(':', Spacing::Joint)),
        TokenTree::Punct(Punct::new(':', Spacing::Alone)),
        TokenTree::Ident(Ident::new("compile_error", Span::call_site())),
        TokenTree::Punct(Punct::new('!', Spacing::Alone)),
        body,
    ]
    .into_iter()
    .collect()
}

/// One lexeme of a token stream: an operator (a run of joint punctuation split into
/// Rust's operators, longest first) or any other token tree.
enum Lex {
    Op(String, Vec<TokenTree>),
    Tree(TokenTree),
}

/// Rust's multi-character operators, longest first.
const OPS: [&str; 24] = [
    "<<=", ">>=", "...", "..=", "::", "->", "=>", "==", "!=", "<=", ">=", "&&", "||", "+=", "-=", "*=", "/=", "%=",
    "^=", "&=", "|=", "<<", ">>", "..",
];

/// Keywords after which an expression starts (`return 2.0 * x`).
const EXPR_KEYWORDS: [&str; 9] = ["return", "break", "if", "match", "while", "in", "yield", "else", "let"];

fn lex(stream: TokenStream) -> Vec<Lex> {
    let mut out = Vec::new();
    let mut run: Vec<Punct> = Vec::new();
    let flush = |run: &mut Vec<Punct>, out: &mut Vec<Lex>| {
        let mut i = 0;
        while i < run.len() {
            let rest: String = run[i..].iter().map(Punct::as_char).collect();
            let len = OPS.iter().find(|op| rest.starts_with(*op)).map_or(1, |op| op.len());
            let text: String = rest.chars().take(len).collect();
            let toks = run[i..i + len].iter().cloned().map(TokenTree::Punct).collect();
            out.push(Lex::Op(text, toks));
            i += len;
        }
        run.clear();
    };
    for tt in stream {
        match tt {
            TokenTree::Punct(p) => {
                let joint = p.spacing() == Spacing::Joint;
                run.push(p);
                if !joint {
                    flush(&mut run, &mut out);
                }
            }
            other => {
                flush(&mut run, &mut out);
                out.push(Lex::Tree(other));
            }
        }
    }
    flush(&mut run, &mut out);
    out
}

/// Where a lexeme leaves the parser: after a value (`x`, `2.0`, `(…)`, `?`) the next
/// operator is binary; anywhere else an expression (or a unary operator) starts.
fn ends_value(l: Option<&Lex>) -> bool {
    match l {
        None => false,
        Some(Lex::Op(op, _)) => op == "?",
        Some(Lex::Tree(TokenTree::Group(g))) => g.delimiter() != Delimiter::Brace,
        Some(Lex::Tree(TokenTree::Ident(i))) => !EXPR_KEYWORDS.contains(&i.to_string().as_str()),
        Some(Lex::Tree(TokenTree::Literal(_))) => true,
        Some(Lex::Tree(TokenTree::Punct(_))) => unreachable!("punctuation is lexed as Op"),
    }
}

/// Whether the float literal `text` (a literal token's text) is one `Lhs` can hold.
fn is_float(text: &str) -> bool {
    let t = text.strip_prefix('-').unwrap_or(text);
    if !t.starts_with(|c: char| c.is_ascii_digit()) || t.starts_with("0x") || t.starts_with("0b") || t.starts_with("0o")
    {
        return false;
    }
    if t.ends_with("f64") {
        return true;
    }
    if t.ends_with("f32") {
        return false;
    }
    const INT_SUFFIXES: [&str; 12] = [
        "u8", "u16", "u32", "u64", "u128", "usize", "i8", "i16", "i32", "i64", "i128", "isize",
    ];
    if INT_SUFFIXES.iter().any(|s| t.ends_with(s)) {
        return false;
    }
    t.contains(['.', 'e', 'E'])
}

/// The tokens of a float literal at `lexes[i]`: a literal, or an invisible group
/// (a `$x:expr` fragment) holding exactly one, possibly negated.
fn float_at(lexes: &[Lex], i: usize) -> bool {
    match lexes.get(i) {
        Some(Lex::Tree(TokenTree::Literal(l))) => is_float(&l.to_string()),
        Some(Lex::Tree(TokenTree::Group(g))) if g.delimiter() == Delimiter::None => {
            let inner: Vec<TokenTree> = g.stream().into_iter().collect();
            match inner.as_slice() {
                [TokenTree::Literal(l)] => is_float(&l.to_string()),
                [TokenTree::Punct(p), TokenTree::Literal(l)] if p.as_char() == '-' => is_float(&l.to_string()),
                _ => false,
            }
        }
        _ => false,
    }
}

fn op_is(l: Option<&Lex>, ops: &[&str]) -> bool {
    matches!(l, Some(Lex::Op(op, _)) if ops.contains(&op.as_str()))
}

/// Whether a literal with lexeme `prev` before it (`None`: start of the group) and
/// `next` after it is the left operand of a binary `+ - * /`.
fn left_operand(lexes: &[Lex], prev: Option<usize>, next: usize) -> bool {
    if !op_is(lexes.get(next), &["+", "-", "*", "/"]) {
        return false;
    }
    let Some(p) = prev else { return true };
    let before_binary = p > 0 && ends_value(lexes.get(p - 1));
    match &lexes[p] {
        Lex::Op(op, _) => match op.as_str() {
            // the right operand of a tighter (or equal, left-associative) operator
            "*" | "/" | "%" | "." | "::" | "!" | "#" | "$" | "@" | "'" | "?" => false,
            "+" | "-" => before_binary && op_is(lexes.get(next), &["*", "/"]),
            // `&2.0` and `&&2.0` are references; `a && 2.0 * x` is a condition
            "&" | "&&" => before_binary,
            _ => true,
        },
        Lex::Tree(TokenTree::Group(g)) => g.delimiter() == Delimiter::Brace,
        Lex::Tree(TokenTree::Ident(i)) => EXPR_KEYWORDS.contains(&i.to_string().as_str()),
        Lex::Tree(_) => false,
    }
}

/// Where a `const`/`static` item (a const context: `Lhs`'s operators are not `const`)
/// ends: at the next `;`, or after the next `{…}` for `const fn` and `const {…}`.
#[derive(Clone, Copy, PartialEq)]
enum ConstEnd {
    Semi,
    Brace,
}

fn is_ident(l: Option<&Lex>, names: &[&str]) -> bool {
    matches!(l, Some(Lex::Tree(TokenTree::Ident(i))) if names.contains(&i.to_string().as_str()))
}

/// `stream` with its float literals on the left of `+ - * /` lifted, groups included;
/// with `lift == false` (inside a const item) only copied.
fn rewrite(stream: TokenStream, krate: &TokenTree, lift: bool) -> TokenStream {
    let lexes = lex(stream);
    let mut out: Vec<TokenTree> = Vec::new();
    let mut in_const: Option<ConstEnd> = None;
    let mut i = 0;
    while i < lexes.len() {
        if in_const.is_none() && is_ident(lexes.get(i), &["const", "static"]) {
            let brace = is_ident(lexes.get(i + 1), &["fn", "unsafe"])
                || matches!(lexes.get(i + 1), Some(Lex::Tree(TokenTree::Group(g))) if g.delimiter() == Delimiter::Brace);
            in_const = Some(if brace { ConstEnd::Brace } else { ConstEnd::Semi });
        }
        if let Some(end) = in_const {
            push(&lexes[i], krate, false, &mut out);
            let ends = match (&lexes[i], end) {
                (Lex::Op(op, _), ConstEnd::Semi) => op == ";",
                (Lex::Tree(TokenTree::Group(g)), ConstEnd::Brace) => g.delimiter() == Delimiter::Brace,
                _ => false,
            };
            if ends {
                in_const = None;
            }
            i += 1;
            continue;
        }
        let prev = i.checked_sub(1);
        // a unary minus followed by a float literal is one operand
        let neg = op_is(lexes.get(i), &["-"]) && !ends_value(prev.map(|p| &lexes[p])) && float_at(&lexes, i + 1);
        let end = if neg { i + 2 } else { i + 1 };
        if lift && (neg || float_at(&lexes, i)) && left_operand(&lexes, prev, end) {
            let mut inner: Vec<TokenTree> = Vec::new();
            for l in &lexes[i..end] {
                push(l, krate, lift, &mut inner);
            }
            let span = inner.last().map_or_else(Span::call_site, TokenTree::span);
            out.extend(lhs_call(krate, inner, span));
            i = end;
            continue;
        }
        for l in &lexes[i..end] {
            push(l, krate, lift, &mut out);
        }
        i = end;
    }
    out.into_iter().collect()
}

/// A lexeme's tokens, groups rewritten recursively.
fn push(l: &Lex, krate: &TokenTree, lift: bool, out: &mut Vec<TokenTree>) {
    match l {
        Lex::Op(_, toks) => out.extend(toks.iter().cloned()),
        Lex::Tree(TokenTree::Group(g)) => {
            let mut ng = Group::new(g.delimiter(), rewrite(g.stream(), krate, lift));
            ng.set_span(g.span());
            out.push(TokenTree::Group(ng));
        }
        Lex::Tree(t) => out.push(t.clone()),
    }
}

/// `$crate::__private::Lhs(inner)`.
fn lhs_call(krate: &TokenTree, inner: Vec<TokenTree>, span: Span) -> Vec<TokenTree> {
    let span = Span::mixed_site().located_at(span);
    let colons = |v: &mut Vec<TokenTree>| {
        let mut a = Punct::new(':', Spacing::Joint);
        a.set_span(span);
        let mut b = Punct::new(':', Spacing::Alone);
        b.set_span(span);
        v.push(TokenTree::Punct(a));
        v.push(TokenTree::Punct(b));
    };
    let mut v = vec![krate.clone()];
    colons(&mut v);
    v.push(TokenTree::Ident(Ident::new("__private", span)));
    colons(&mut v);
    v.push(TokenTree::Ident(Ident::new("Lhs", span)));
    let mut g = Group::new(Delimiter::Parenthesis, inner.into_iter().collect());
    g.set_span(span);
    v.push(TokenTree::Group(g));
    v
}

/// `mentions!(name, body)`: `true` when the identifier `name` occurs anywhere in `body`
/// (inside groups and macro calls too), `false` otherwise. `model!` asks it whether a body
/// reads its plain-`f64` time: a body that never names `t` cannot depend on it (a local
/// variable is reachable only by its name), one that does is refused by the trace.
#[proc_macro]
pub fn mentions(input: TokenStream) -> TokenStream {
    let mut it = input.into_iter();
    let name = match it.next() {
        Some(TokenTree::Ident(i)) => i.to_string(),
        // `_` (no name) cannot be read
        Some(TokenTree::Punct(p)) if p.as_char() == '_' => String::new(),
        Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::None => match g.stream().into_iter().next() {
            Some(TokenTree::Ident(i)) => i.to_string(),
            _ => String::new(),
        },
        _ => return error("mentions!: expected `name, body`"),
    };
    match it.next() {
        Some(TokenTree::Punct(p)) if p.as_char() == ',' => {}
        _ => return error("mentions!: expected `name, body`"),
    }
    let found = !name.is_empty() && name != "_" && occurs(it.collect(), &name);
    TokenTree::Ident(Ident::new(if found { "true" } else { "false" }, Span::call_site())).into()
}

fn occurs(stream: TokenStream, name: &str) -> bool {
    stream.into_iter().any(|tt| match tt {
        TokenTree::Ident(i) => i.to_string() == name,
        TokenTree::Group(g) => occurs(g.stream(), name),
        _ => false,
    })
}
