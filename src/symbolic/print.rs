//! Printing expressions: plain text (`−v·sin(θ)`), LaTeX, MathML and Rust source.
//!
//! Parentheses are the minimal ones for the usual precedence (sums < products and
//! quotients and negation < powers < atoms); in Rust a product's or quotient's right
//! operand keeps its parentheses when it is itself a product or quotient, so that the
//! printed Rust evaluates in the graph's order (bit for bit the compiled evaluator's
//! values).
//!
//! For a reader (text, LaTeX, MathML) a product is printed in a normal form: its numeric
//! factors and signs folded into one leading coefficient, then the states (by index), the
//! inputs, the time, then the other factors in the order the model wrote them, a factor
//! repeated side by side written as a power: `x₁·2·x₀·1000` prints `2000·x₀·x₁`, `x₁·x₁`
//! prints `x₁²`, and a sum's negative term is subtracted (`a + (−2)·x` prints `a − 2·x`).

use super::Names;
use super::graph::{Func, Graph, Node};
use std::collections::HashMap;
use std::fmt::Write;

#[derive(Clone, Copy, PartialEq)]
enum Lang {
    Text,
    Latex,
    MathMl,
    Rust,
}

/// Precedence of the node's printed form.
fn prec(g: &Graph, id: u32) -> u8 {
    match g.node(id) {
        Node::Const(b) if f64::from_bits(b) < 0.0 || f64::from_bits(b).is_sign_negative() => 2,
        Node::Const(_)
        | Node::State(_)
        | Node::Input(_)
        | Node::Time
        | Node::Param(_)
        | Node::F(..)
        | Node::Atan2(..) => 5,
        Node::Add(..) | Node::Sub(..) => 1,
        Node::Mul(..) | Node::Div(..) | Node::Rem(..) | Node::Neg(_) => 2,
        Node::Powi(..) | Node::Powf(..) => 4,
    }
}

/// `v` as a human reads it: `2`, `0.5`, `1e-10`, `6.02e23` (shortest round trip).
pub(crate) fn number(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else if v.abs() >= 1e-4 && v.abs() < 1e15 {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `v` as a Rust `f64` literal that reads back to the same bits.
pub(crate) fn rust_number(v: f64) -> String {
    if v.is_nan() {
        "f64::NAN".into()
    } else if v.is_infinite() {
        if v > 0.0 {
            "f64::INFINITY".into()
        } else {
            "f64::NEG_INFINITY".into()
        }
    } else {
        format!("{v:?}")
    }
}

const SUB: [char; 10] = ['₀', '₁', '₂', '₃', '₄', '₅', '₆', '₇', '₈', '₉'];
const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

/// `i` in subscript digits.
pub(crate) fn subscript(i: usize) -> String {
    i.to_string().chars().map(|c| SUB[c as usize - '0' as usize]).collect()
}

fn superscript(n: i32) -> String {
    let mut s = String::new();
    if n < 0 {
        s.push('⁻');
    }
    s.extend(
        n.unsigned_abs()
            .to_string()
            .chars()
            .map(|c| SUP[c as usize - '0' as usize]),
    );
    s
}

/// Greek letters LaTeX spells by name.
const GREEK: [(char, &str); 30] = [
    ('α', "alpha"),
    ('β', "beta"),
    ('γ', "gamma"),
    ('δ', "delta"),
    ('ε', "varepsilon"),
    ('ζ', "zeta"),
    ('η', "eta"),
    ('θ', "theta"),
    ('ι', "iota"),
    ('κ', "kappa"),
    ('λ', "lambda"),
    ('μ', "mu"),
    ('ν', "nu"),
    ('ξ', "xi"),
    ('π', "pi"),
    ('ρ', "rho"),
    ('σ', "sigma"),
    ('τ', "tau"),
    ('υ', "upsilon"),
    ('φ', "varphi"),
    ('χ', "chi"),
    ('ψ', "psi"),
    ('ω', "omega"),
    ('Γ', "Gamma"),
    ('Δ', "Delta"),
    ('Θ', "Theta"),
    ('Λ', "Lambda"),
    ('Φ', "Phi"),
    ('Ψ', "Psi"),
    ('Ω', "Omega"),
];

/// A name split into its base and a trailing subscript (`x₀` → (`x`, `0`), `v_l` → (`v`, `l`)).
fn split_name(name: &str) -> (String, String) {
    if let Some((a, b)) = name.split_once('_') {
        return (a.to_string(), b.to_string());
    }
    let base: String = name.chars().filter(|c| !SUB.contains(c)).collect();
    let sub: String = name
        .chars()
        .filter_map(|c| SUB.iter().position(|&s| s == c).map(|d| char::from(b'0' + d as u8)))
        .collect();
    (base, sub)
}

/// A name in LaTeX: Greek letters as commands, a subscript as `_{…}`.
pub(crate) fn latex_name(name: &str) -> String {
    let (base, sub) = split_name(name);
    let mut s = String::new();
    for c in base.chars() {
        match GREEK.iter().find(|(g, _)| *g == c) {
            Some((_, cmd)) => {
                let _ = write!(s, "\\{cmd} ");
            }
            None => s.push(c),
        }
    }
    let mut s = s.trim_end().to_string();
    if !sub.is_empty() {
        let _ = write!(s, "_{{{sub}}}");
    }
    s
}

/// A name in MathML (`<mi>θ</mi>`, `<msub><mi>x</mi><mn>0</mn></msub>`).
pub(crate) fn mathml_name(name: &str) -> String {
    let (base, sub) = split_name(name);
    let base = escape(&base);
    if sub.is_empty() {
        format!("<mi>{base}</mi>")
    } else if sub.chars().all(|c| c.is_ascii_digit()) {
        format!("<msub><mi>{base}</mi><mn>{sub}</mn></msub>")
    } else {
        format!("<msub><mi>{base}</mi><mi>{}</mi></msub>", escape(&sub))
    }
}

/// MathML fences that stretch to their content (with a math font, see the report's CSS).
pub(crate) const OPEN: &str = "<mo stretchy=\"true\" fence=\"true\">(</mo>";
pub(crate) const CLOSE: &str = "<mo stretchy=\"true\" fence=\"true\">)</mo>";

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

struct Printer<'a> {
    g: &'a Graph,
    names: &'a Names,
    lang: Lang,
    /// Nodes printed as a bound name instead of their expression (Rust's `let`s).
    bound: &'a HashMap<u32, String>,
}

impl Printer<'_> {
    fn leaf(&self, node: Node) -> Option<String> {
        let name = |s: String| match self.lang {
            Lang::Text | Lang::Rust => s,
            Lang::Latex => latex_name(&s),
            Lang::MathMl => mathml_name(&s),
        };
        Some(match node {
            Node::State(i) if self.lang == Lang::Rust => format!("x[{i}]"),
            Node::Input(k) if self.lang == Lang::Rust => format!("u[{k}]"),
            Node::Time if self.lang == Lang::Rust => "t".into(),
            Node::Param(k) if self.lang == Lang::Rust => format!("p[{k}]"),
            Node::Param(k) => name(self.names.param(k as usize)),
            Node::State(i) => name(self.names.state(i as usize)),
            Node::Input(k) => name(self.names.input(k as usize)),
            Node::Time => name(self.names.time()),
            Node::Const(b) => {
                let v = f64::from_bits(b);
                match self.lang {
                    Lang::Rust => rust_number(v),
                    Lang::Text => number(v).replace('-', "−"),
                    Lang::Latex => {
                        let s = number(v);
                        match s.split_once('e') {
                            Some((m, e)) => format!("{m} \\cdot 10^{{{e}}}"),
                            None => s,
                        }
                    }
                    Lang::MathMl => {
                        if v < 0.0 {
                            format!("<mrow><mo>−</mo><mn>{}</mn></mrow>", number(-v))
                        } else {
                            format!("<mn>{}</mn>", number(v))
                        }
                    }
                }
            }
            _ => return None,
        })
    }

    fn paren(&self, s: String) -> String {
        match self.lang {
            Lang::Text | Lang::Rust => format!("({s})"),
            Lang::Latex => format!("\\left({s}\\right)"),
            Lang::MathMl => format!("<mrow>{OPEN}{s}{CLOSE}</mrow>"),
        }
    }

    /// A product's normal form: the numeric coefficient (constants and negations folded)
    /// and the other factors, states first (by index), then inputs, the time and the rest
    /// in their order, each with its multiplicity when it repeats (`x·x` → `(x, 2)`).
    fn product(&self, id: u32) -> (f64, Vec<(u32, i32)>) {
        fn collect(p: &Printer<'_>, id: u32, c: &mut f64, out: &mut Vec<u32>) {
            if !p.bound.contains_key(&id) {
                match p.g.node(id) {
                    Node::Mul(a, b) => {
                        collect(p, a, c, out);
                        collect(p, b, c, out);
                        return;
                    }
                    Node::Neg(a) => {
                        *c = -*c;
                        collect(p, a, c, out);
                        return;
                    }
                    Node::Const(b) => {
                        *c *= f64::from_bits(b);
                        return;
                    }
                    _ => {}
                }
            }
            out.push(id);
        }
        let (mut c, mut fs) = (1.0, Vec::new());
        collect(self, id, &mut c, &mut fs);
        let rank = |id: &u32| match self.g.node(*id) {
            Node::State(i) => (0, i),
            Node::Input(k) => (1, k),
            Node::Time => (2, 0),
            _ => (3, 0),
        };
        // stable: the other factors keep the model's order
        fs.sort_by_key(rank);
        let mut grouped: Vec<(u32, i32)> = Vec::new();
        for f in fs {
            match grouped.last_mut() {
                Some((g, n)) if *g == f => *n += 1,
                _ => grouped.push((f, 1)),
            }
        }
        (c, grouped)
    }

    /// A product (or negation) in its normal form (see [`Printer::product`]), as
    /// `(negative, magnitude)`: the sign of its coefficient and the rest printed.
    fn signed_product(&self, id: u32) -> (bool, String) {
        let (c, factors) = self.product(id);
        let sep = match self.lang {
            Lang::Text | Lang::MathMl => "·",
            Lang::Latex => " \\, ",
            Lang::Rust => " * ",
        };
        let mut parts = Vec::new();
        if c.abs() != 1.0 || factors.is_empty() || c.is_nan() {
            parts.push(self.leaf(Node::Const(c.abs().to_bits())).unwrap_or_default());
        }
        for (f, n) in factors {
            parts.push(if n == 1 {
                // parentheses only around a sum
                self.wrap(f, 2)
            } else {
                self.power(self.wrap(f, 5), n)
            });
        }
        let body = match self.lang {
            Lang::MathMl => {
                let mut s = String::from("<mrow>");
                for (k, p) in parts.iter().enumerate() {
                    if k > 0 {
                        s += "<mo>·</mo>";
                    }
                    s += p;
                }
                s + "</mrow>"
            }
            _ => parts.join(sep),
        };
        (c.is_sign_negative() && !c.is_nan(), body)
    }

    fn power(&self, base: String, n: i32) -> String {
        match self.lang {
            Lang::Text => format!("{base}{}", superscript(n)),
            Lang::Latex => format!("{{{base}}}^{{{n}}}"),
            Lang::MathMl => format!("<msup>{base}<mn>{n}</mn></msup>"),
            Lang::Rust => format!("{base}.powi({n})"),
        }
    }

    /// A term of a sum for a reader: `(negative, magnitude)`, the magnitude wrapped for a
    /// sum's right operand (negative constants, negations and products with a negative
    /// coefficient are subtracted).
    fn term(&self, id: u32) -> (bool, String) {
        if !self.bound.contains_key(&id) {
            match self.g.node(id) {
                Node::Const(b) if f64::from_bits(b) < 0.0 => {
                    return (
                        true,
                        self.leaf(Node::Const((-f64::from_bits(b)).to_bits()))
                            .unwrap_or_default(),
                    );
                }
                Node::Mul(..) | Node::Neg(_) => return self.signed_product(id),
                _ => {}
            }
        }
        (false, self.wrap(id, 2))
    }

    /// `id` printed, parenthesised when its precedence is below `min`.
    fn wrap(&self, id: u32, min: u8) -> String {
        let s = self.expr(id);
        if !self.bound.contains_key(&id) && prec(self.g, id) < min {
            self.paren(s)
        } else {
            s
        }
    }

    fn op(&self, a: String, text: &str, b: String) -> String {
        match self.lang {
            Lang::MathMl => format!("<mrow>{a}<mo>{text}</mo>{b}</mrow>"),
            _ => format!("{a}{text}{b}"),
        }
    }

    fn expr(&self, id: u32) -> String {
        if let Some(name) = self.bound.get(&id) {
            return name.clone();
        }
        let node = self.g.node(id);
        if let Some(s) = self.leaf(node) {
            return s;
        }
        let l = self.lang;
        let minus = match l {
            Lang::Text | Lang::MathMl => "−",
            Lang::Latex | Lang::Rust => "-",
        };
        match node {
            Node::Neg(_) | Node::Mul(..) if l != Lang::Rust => {
                let (neg, s) = self.signed_product(id);
                match (neg, l) {
                    (false, _) => s,
                    (true, Lang::MathMl) => format!("<mrow><mo>−</mo>{s}</mrow>"),
                    (true, _) => format!("{minus}{s}"),
                }
            }
            Node::Add(a, b) | Node::Sub(a, b) if l != Lang::Rust => {
                // a negative term is subtracted, a subtracted negative one added
                let sub = matches!(node, Node::Sub(..));
                let (neg, mag) = self.term(b);
                let (op, s) = match (sub, neg) {
                    (false, false) => (" + ".to_string(), self.wrap(b, 1)),
                    (false, true) | (true, false) => (format!(" {minus} "), mag),
                    (true, true) => (" + ".to_string(), mag),
                };
                self.op(self.wrap(a, 1), &op, s)
            }
            Node::Neg(a) => {
                let s = self.wrap(a, 2);
                format!("{minus}{s}")
            }
            Node::Add(a, b) => self.op(self.wrap(a, 1), " + ", self.wrap(b, 2)),
            Node::Sub(a, b) => self.op(self.wrap(a, 1), &format!(" {minus} "), self.wrap(b, 2)),
            Node::Mul(a, b) => {
                let sep = match l {
                    Lang::Text => "·",
                    Lang::Latex => " \\, ",
                    Lang::MathMl => "·",
                    Lang::Rust => " * ",
                };
                // a product on the right keeps its parentheses in Rust (evaluation order)
                // and a negation everywhere (`a·(−b)`)
                let neg = matches!(self.g.node(b), Node::Neg(_)) || self.g.constant(b).is_some_and(|v| v < 0.0);
                self.op(
                    self.wrap(a, 2),
                    sep,
                    self.wrap(b, if l == Lang::Rust || neg { 3 } else { 2 }),
                )
            }
            Node::Div(a, b) => match l {
                Lang::Latex => format!("\\frac{{{}}}{{{}}}", self.expr(a), self.expr(b)),
                Lang::MathMl => format!("<mfrac>{}{}</mfrac>", self.row(a), self.row(b)),
                _ => self.op(
                    self.wrap(a, 2),
                    if l == Lang::Rust { " / " } else { "/" },
                    self.wrap(b, 3),
                ),
            },
            Node::Rem(a, b) => match l {
                Lang::Latex => format!("{} \\bmod {}", self.wrap(a, 3), self.wrap(b, 3)),
                Lang::MathMl => self.op(self.wrap(a, 3), "mod", self.wrap(b, 3)),
                _ => self.op(self.wrap(a, 2), " % ", self.wrap(b, 3)),
            },
            Node::Powi(a, n) => match l {
                Lang::Text => format!("{}{}", self.wrap(a, 5), superscript(n)),
                Lang::Latex => format!("{{{}}}^{{{n}}}", self.wrap(a, 5)),
                Lang::MathMl => format!("<msup>{}<mn>{n}</mn></msup>", self.wrap(a, 5)),
                Lang::Rust => format!("{}.powi({n})", self.wrap(a, 5)),
            },
            Node::Powf(a, p) => {
                let p = f64::from_bits(p);
                match l {
                    Lang::Text => format!("{}^{}", self.wrap(a, 5), number(p)),
                    Lang::Latex => format!("{{{}}}^{{{}}}", self.wrap(a, 5), number(p)),
                    Lang::MathMl => format!("<msup>{}<mn>{}</mn></msup>", self.wrap(a, 5), number(p)),
                    Lang::Rust => format!("{}.powf({})", self.wrap(a, 5), rust_number(p)),
                }
            }
            Node::Atan2(a, b) => match l {
                Lang::Rust => format!("{}.atan2({})", self.wrap(a, 5), self.expr(b)),
                Lang::Latex => format!(
                    "\\operatorname{{atan2}}\\left({}, {}\\right)",
                    self.expr(a),
                    self.expr(b)
                ),
                Lang::MathMl => format!(
                    "<mrow><mi>atan2</mi><mo>&#x2061;</mo><mrow>{OPEN}{}<mo>,</mo>{}{CLOSE}</mrow></mrow>",
                    self.expr(a),
                    self.expr(b)
                ),
                Lang::Text => format!("atan2({}, {})", self.expr(a), self.expr(b)),
            },
            Node::F(f, a) => self.func(f, a),
            Node::Const(_) | Node::State(_) | Node::Input(_) | Node::Time | Node::Param(_) => {
                unreachable!("leaves print above")
            }
        }
    }

    fn row(&self, id: u32) -> String {
        format!("<mrow>{}</mrow>", self.expr(id))
    }

    fn func(&self, f: Func, a: u32) -> String {
        let arg = self.expr(a);
        match self.lang {
            Lang::Rust => format!("{}.{}()", self.wrap(a, 5), f.name()),
            Lang::Text => match f {
                Func::Abs => format!("|{arg}|"),
                Func::Sqrt => format!("√({arg})"),
                Func::Sign => format!("sgn({arg})"),
                Func::ExpM1 => format!("expm1({arg})"),
                Func::Ln1p => format!("ln1p({arg})"),
                _ => format!("{}({arg})", f.name()),
            },
            Lang::Latex => match f {
                Func::Abs => format!("\\left|{arg}\\right|"),
                Func::Sqrt => format!("\\sqrt{{{arg}}}"),
                Func::Cbrt => format!("\\sqrt[3]{{{arg}}}"),
                Func::Exp => format!("e^{{{arg}}}"),
                _ => {
                    let cmd = match f {
                        Func::Sin => "\\sin".to_string(),
                        Func::Cos => "\\cos".into(),
                        Func::Tan => "\\tan".into(),
                        Func::Ln => "\\ln".into(),
                        Func::Sinh => "\\sinh".into(),
                        Func::Cosh => "\\cosh".into(),
                        Func::Tanh => "\\tanh".into(),
                        Func::Asin => "\\arcsin".into(),
                        Func::Acos => "\\arccos".into(),
                        Func::Atan => "\\arctan".into(),
                        Func::Sign => "\\operatorname{sgn}".into(),
                        other => format!("\\operatorname{{{}}}", other.name().replace('_', "\\_")),
                    };
                    // a name needs no parentheses: `\sin \theta`, `\cos x_{0}`
                    if matches!(
                        self.g.node(a),
                        Node::State(_) | Node::Input(_) | Node::Time | Node::Param(_)
                    ) {
                        format!("{cmd} {arg}")
                    } else {
                        format!("{cmd}\\left({arg}\\right)")
                    }
                }
            },
            Lang::MathMl => match f {
                Func::Abs => format!("<mrow><mo>|</mo>{arg}<mo>|</mo></mrow>"),
                Func::Sqrt => format!("<msqrt>{arg}</msqrt>"),
                Func::Cbrt => format!("<mroot><mrow>{arg}</mrow><mn>3</mn></mroot>"),
                Func::Exp => format!("<msup><mi>e</mi><mrow>{arg}</mrow></msup>"),
                _ => {
                    let name = match f {
                        Func::Sign => "sgn",
                        Func::ExpM1 => "expm1",
                        Func::Ln1p => "ln1p",
                        other => other.name(),
                    };
                    format!("<mrow><mi>{name}</mi><mo>&#x2061;</mo><mrow>{OPEN}{arg}{CLOSE}</mrow></mrow>")
                }
            },
        }
    }
}

fn print(g: &Graph, id: u32, names: &Names, lang: Lang) -> String {
    let bound = HashMap::new();
    Printer {
        g,
        names,
        lang,
        bound: &bound,
    }
    .expr(id)
}

/// `id` as plain text.
pub(crate) fn text(g: &Graph, id: u32, names: &Names) -> String {
    print(g, id, names, Lang::Text)
}

/// `id` as LaTeX (math mode).
pub(crate) fn latex(g: &Graph, id: u32, names: &Names) -> String {
    print(g, id, names, Lang::Latex)
}

/// `id` as presentation MathML (the content of a `<math>` element).
pub(crate) fn mathml(g: &Graph, id: u32, names: &Names) -> String {
    print(g, id, names, Lang::MathMl)
}

/// The statements of a Rust function body that assigns `targets[k] = roots[k]`:
/// subexpressions used more than once bound by `let`, in dependency order.
pub(crate) fn rust_body(g: &Graph, targets: &[(String, u32)], names: &Names, indent: &str) -> String {
    // users of each node reachable from the roots
    let mut uses: HashMap<u32, u32> = HashMap::new();
    let mut stack: Vec<u32> = targets.iter().map(|t| t.1).collect();
    let mut seen = std::collections::HashSet::new();
    while let Some(id) = stack.pop() {
        if !seen.insert(id) {
            continue;
        }
        let (args, k) = g.node(id).args();
        for &a in &args[..k] {
            *uses.entry(a).or_insert(0) += 1;
            stack.push(a);
        }
    }
    for t in targets {
        *uses.entry(t.1).or_insert(0) += 1;
    }
    let mut shared: Vec<u32> = uses
        .iter()
        .filter(|&(&id, &n)| n > 1 && g.node(id).args().1 > 0)
        .map(|(&id, _)| id)
        .collect();
    shared.sort_unstable();
    let mut bound: HashMap<u32, String> = HashMap::new();
    let mut out = String::new();
    for (k, &id) in shared.iter().enumerate() {
        let p = Printer {
            g,
            names,
            lang: Lang::Rust,
            bound: &bound,
        };
        let _ = writeln!(out, "{indent}let v{k} = {};", p.expr(id));
        bound.insert(id, format!("v{k}"));
    }
    let p = Printer {
        g,
        names,
        lang: Lang::Rust,
        bound: &bound,
    };
    for (target, id) in targets {
        let _ = writeln!(out, "{indent}{target} = {};", p.expr(*id));
    }
    out
}
