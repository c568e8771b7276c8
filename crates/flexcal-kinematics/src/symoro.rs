//! SYMORO / OpenSYMORO `.par` files: the geometric part (NL, NJ, NF, `Ant`,
//! `Sigma`, `Mu`, `gamma`, `B`, `Alpha`, `d`, `Theta`, `R`) read into a
//! Khalil-Kleinfinger [`RobotDescription`]; the dynamic parameters are ignored.
//!
//! Layout (Khalil and Kleinfinger's numbering, as SYMORO writes it): frames
//! 1..NL are the links, NL+1..NJ the cut joints of closed loops and
//! NJ+1..NF (sigma = 2) the frames that coincide with them, so that
//! NF = NJ + (NJ - NL); each pair (NL+i, NJ+i) becomes a flexcal loop with a
//! full closure constraint. Where there are loops `Mu` = 1 marks actuated
//! joints and passive joints must lie in a loop; a robot without loops has
//! every joint actuated whatever its `Mu` (SYMORO writes `Mu = 0` there),
//! and its notes say so.
//!
//! Entries are numbers or expressions (`+ - * /`, `^` or `**`, unary minus,
//! parentheses, `Pi`, the functions `sin cos tan sqrt atan2` in any case,
//! with `(` or Mathematica's `[`) of symbols whose values (SI: m, rad) come
//! from a values file; an error names the character where an entry stops
//! making sense:
//!
//! ```toml
//! D3 = 0.45          # symbol = value (m or rad)
//! RL4 = 0.45
//! [home]             # optional: joint values that pick each loop's assembly branch
//! th2 = 0.3
//! ```
//!
//! In `Theta` of a revolute joint (`R` of a prismatic one) the one symbol
//! without a value is the joint variable, which must appear with
//! coefficient 1 (`th2`, `th2 - Pi/2`); it names the actuated coordinate.
//!
//! The end frame is the one link frame that carries no other frame; a tree
//! with several (a hand's fingertips) needs `tip`, and every other leaf's
//! pose is read from [`crate::Data::frame_pose`]. A loop that is a planar
//! four-bar (a parallelogram) is closed in closed form on the assembly
//! branch of the `[home]` configuration when it gives every actuated and
//! passive joint; other loops are followed by continuation from the home
//! configuration (the actuated frames' seeds, see
//! [`crate::Model::home_configuration`]), and the import's notes say which.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::KinematicsError;
use crate::description::{
    FrameDescription, JointType, LoopConstraint, LoopDescription, LoopSolver, RobotDescription,
    TransformDescription,
};
use crate::import::{ImportOptions, ImportedRobot};

fn par_error(source: &str, line: usize, message: impl Into<String>) -> KinematicsError {
    KinematicsError::Symoro {
        source_name: source.to_string(),
        line,
        message: message.into(),
    }
}

/// An arithmetic expression of a `.par` entry.
#[derive(Debug, Clone, PartialEq)]
enum Expr {
    Number(f64),
    Symbol(String),
    Negate(Box<Expr>),
    /// `+ - * /` and `^` (`**` is read as `^`).
    Binary(char, Box<Expr>, Box<Expr>),
    Call(Function, Vec<Expr>),
}

/// The functions an entry may call (SYMORO's and Mathematica's spellings,
/// any case: `cos`, `Cos`, `COS`; `ArcTan` and `atan2` take two arguments
/// in the order `atan2(y, x)`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Function {
    Sin,
    Cos,
    Tan,
    Sqrt,
    Atan2,
}

impl Function {
    fn named(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "sin" => Some(Self::Sin),
            "cos" => Some(Self::Cos),
            "tan" => Some(Self::Tan),
            "sqrt" => Some(Self::Sqrt),
            "atan2" => Some(Self::Atan2),
            _ => None,
        }
    }

    fn arity(self) -> usize {
        if self == Self::Atan2 { 2 } else { 1 }
    }

    fn apply(self, args: &[f64]) -> f64 {
        match self {
            Self::Sin => args[0].sin(),
            Self::Cos => args[0].cos(),
            Self::Tan => args[0].tan(),
            Self::Sqrt => args[0].sqrt(),
            Self::Atan2 => args[0].atan2(args[1]),
        }
    }
}

impl Expr {
    fn symbols(&self, out: &mut BTreeSet<String>) {
        match self {
            Expr::Number(_) => {}
            Expr::Symbol(s) => {
                out.insert(s.clone());
            }
            Expr::Negate(e) => e.symbols(out),
            Expr::Binary(_, a, b) => {
                a.symbols(out);
                b.symbols(out);
            }
            Expr::Call(_, args) => args.iter().for_each(|a| a.symbols(out)),
        }
    }

    fn eval(&self, value: &dyn Fn(&str) -> f64) -> f64 {
        match self {
            Expr::Number(x) => *x,
            Expr::Symbol(s) => value(s),
            Expr::Negate(e) => -e.eval(value),
            Expr::Binary(op, a, b) => {
                let (a, b) = (a.eval(value), b.eval(value));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '^' => a.powf(b),
                    _ => a / b,
                }
            }
            Expr::Call(f, args) => {
                let values: Vec<f64> = args.iter().map(|a| a.eval(value)).collect();
                f.apply(&values)
            }
        }
    }
}

/// Recursive-descent parser of one entry. Precedence, loosest first:
/// `+ -`, `* /`, unary `- +`, `^` (right-associative, so `-x^2 = -(x^2)`
/// and `2^3^2 = 2^9`), then numbers, symbols, `Pi`, calls and parentheses.
/// Errors name the character (1-based) where the entry stops making sense.
struct Parser<'a> {
    chars: Vec<char>,
    at: usize,
    text: &'a str,
}

impl Parser<'_> {
    fn skip(&mut self) {
        while self.at < self.chars.len() && self.chars[self.at].is_whitespace() {
            self.at += 1;
        }
    }
    fn peek(&mut self) -> Option<char> {
        self.skip();
        self.chars.get(self.at).copied()
    }
    /// An error at the current character: `what at character 7 of `text``.
    fn error(&mut self, what: &str) -> String {
        self.skip();
        if self.at >= self.chars.len() {
            format!("{what} at the end of `{}`", self.text)
        } else {
            format!(
                "{what} at character {} (`{}`) of `{}`",
                self.at + 1,
                self.chars[self.at],
                self.text
            )
        }
    }
    fn sum(&mut self, depth: usize) -> Result<Expr, String> {
        let mut left = self.product(depth)?;
        while let Some(op @ ('+' | '-')) = self.peek() {
            self.at += 1;
            let right = self.product(depth)?;
            left = Expr::Binary(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }
    /// `*` and `/`, but not `**` (the power).
    fn product(&mut self, depth: usize) -> Result<Expr, String> {
        let mut left = self.unary(depth)?;
        while let Some(op @ ('*' | '/')) = self.peek() {
            if op == '*' && self.chars.get(self.at + 1) == Some(&'*') {
                break;
            }
            self.at += 1;
            let right = self.unary(depth)?;
            left = Expr::Binary(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }
    fn unary(&mut self, depth: usize) -> Result<Expr, String> {
        if depth > 64 {
            return Err(self.error("nested too deeply"));
        }
        match self.peek() {
            Some('-') => {
                self.at += 1;
                Ok(Expr::Negate(Box::new(self.unary(depth + 1)?)))
            }
            Some('+') => {
                self.at += 1;
                self.unary(depth + 1)
            }
            _ => self.power(depth),
        }
    }
    /// A primary, raised to a power by `^` or `**` (right-associative).
    fn power(&mut self, depth: usize) -> Result<Expr, String> {
        let base = self.primary(depth)?;
        let width = match self.peek() {
            Some('^') => 1,
            Some('*') if self.chars.get(self.at + 1) == Some(&'*') => 2,
            _ => return Ok(base),
        };
        self.at += width;
        let exponent = self.unary(depth + 1)?;
        Ok(Expr::Binary('^', Box::new(base), Box::new(exponent)))
    }
    fn primary(&mut self, depth: usize) -> Result<Expr, String> {
        match self.peek() {
            Some('(') => {
                self.at += 1;
                let e = self.sum(depth + 1)?;
                if self.peek() != Some(')') {
                    return Err(self.error("expected `)`"));
                }
                self.at += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_alphabetic() || c == '_' => self.name(depth),
            Some(_) => Err(self.error("unexpected character")),
            None => Err(self.error("an operand is missing")),
        }
    }
    fn number(&mut self) -> Result<Expr, String> {
        let start = self.at;
        while self.at < self.chars.len() {
            let c = self.chars[self.at];
            let exponent_sign = (c == '-' || c == '+')
                && self.at > start
                && matches!(self.chars[self.at - 1], 'e' | 'E');
            if c.is_ascii_digit() || c == '.' || c == 'e' || c == 'E' || exponent_sign {
                self.at += 1;
            } else {
                break;
            }
        }
        let s: String = self.chars[start..self.at].iter().collect();
        match s.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(Expr::Number(x)),
            _ => {
                self.at = start;
                Err(self.error(&format!("`{s}` is not a finite number")))
            }
        }
    }
    /// A symbol, `Pi`, or a function call `name(args)` (or `Name[args]`).
    fn name(&mut self, depth: usize) -> Result<Expr, String> {
        let start = self.at;
        while self.at < self.chars.len()
            && (self.chars[self.at].is_alphanumeric() || self.chars[self.at] == '_')
        {
            self.at += 1;
        }
        let s: String = self.chars[start..self.at].iter().collect();
        let close = match self.peek() {
            Some('(') => ')',
            Some('[') => ']',
            _ if s.eq_ignore_ascii_case("pi") => return Ok(Expr::Number(std::f64::consts::PI)),
            _ => return Ok(Expr::Symbol(s)),
        };
        let Some(function) = Function::named(&s) else {
            self.at = start;
            return Err(self.error(&format!(
                "unknown function `{s}` (known: sin, cos, tan, sqrt, atan2)"
            )));
        };
        self.at += 1;
        let mut args = vec![self.sum(depth + 1)?];
        while self.peek() == Some(',') {
            self.at += 1;
            args.push(self.sum(depth + 1)?);
        }
        if self.peek() != Some(close) {
            return Err(self.error(&format!("expected `{close}` closing `{s}`")));
        }
        if args.len() != function.arity() {
            return Err(self.error(&format!(
                "`{s}` takes {} argument(s), found {}",
                function.arity(),
                args.len()
            )));
        }
        self.at += 1;
        Ok(Expr::Call(function, args))
    }
}

fn parse_expr(text: &str) -> Result<Expr, String> {
    let mut p = Parser {
        chars: text.chars().collect(),
        at: 0,
        text,
    };
    let e = p.sum(0)?;
    if p.peek().is_some() {
        return Err(p.error("unexpected text after the expression"));
    }
    Ok(e)
}

/// Removes `(* ... *)` comments, keeping line breaks for line numbers.
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut depth = 0usize;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '(' && chars.peek() == Some(&'*') {
            chars.next();
            depth += 1;
        } else if depth > 0 && c == '*' && chars.peek() == Some(&')') {
            chars.next();
            depth -= 1;
        } else if depth == 0 || c == '\n' {
            out.push(if depth > 0 { '\n' } else { c });
        }
    }
    out
}

/// The assignments of a `.par` file: key (lower case) -> (line, entries).
fn assignments(
    text: &str,
    source: &str,
) -> Result<BTreeMap<String, (usize, Vec<String>)>, KinematicsError> {
    let text = strip_comments(text);
    let mut out = BTreeMap::new();
    let mut pending: Option<(String, usize, String)> = None;
    for (k, line) in text.lines().enumerate() {
        let number = k + 1;
        if let Some((key, start, mut value)) = pending.take() {
            value.push_str(line);
            if value.contains('}') {
                out.insert(key, (start, list_entries(&value, source, start)?));
            } else {
                pending = Some((key, start, value));
            }
            continue;
        }
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(par_error(
                source,
                number,
                format!("`{line}` is no `name = value` line"),
            ));
        };
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim().to_string();
        if value.starts_with('{') && !value.contains('}') {
            pending = Some((key, number, value));
        } else if value.starts_with('{') {
            out.insert(key, (number, list_entries(&value, source, number)?));
        } else {
            out.insert(
                key,
                (number, vec![value.trim_end_matches(';').trim().to_string()]),
            );
        }
    }
    if let Some((key, start, _)) = pending {
        return Err(par_error(
            source,
            start,
            format!("the list `{key}` has no closing `}}`"),
        ));
    }
    Ok(out)
}

fn list_entries(value: &str, source: &str, line: usize) -> Result<Vec<String>, KinematicsError> {
    let open = value.find('{').unwrap_or(0);
    let close = value
        .rfind('}')
        .ok_or_else(|| par_error(source, line, "a list has no closing `}`"))?;
    if close < open {
        return Err(par_error(source, line, "a list closes before it opens"));
    }
    // Commas inside a call's parentheses (`atan2(y, x)`) do not separate entries.
    let mut entries = Vec::new();
    let (mut depth, mut start) = (0i32, open + 1);
    for (k, c) in value[..close]
        .char_indices()
        .skip_while(|&(k, _)| k <= open)
    {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            ',' if depth == 0 => {
                entries.push(value[start..k].trim().to_string());
                start = k + 1;
            }
            _ => {}
        }
    }
    entries.push(value[start..close].trim().to_string());
    Ok(entries)
}

/// Symbol values and the home configuration of a values file.
#[derive(Default)]
struct Values {
    symbols: BTreeMap<String, f64>,
    home: BTreeMap<String, f64>,
}

fn read_values(path: &Path) -> Result<Values, KinematicsError> {
    let source = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| KinematicsError::File {
        path: source.clone(),
        message: e.to_string(),
    })?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
            .unwrap_or(0);
        KinematicsError::Toml {
            source_name: source.clone(),
            line,
            message: e.message().to_string(),
        }
    })?;
    let number = |key: &str, v: &toml::Value| -> Result<f64, KinematicsError> {
        let x = match v {
            toml::Value::Float(x) => *x,
            toml::Value::Integer(i) => *i as f64,
            _ => {
                return Err(KinematicsError::Toml {
                    source_name: source.clone(),
                    line: 0,
                    message: format!("`{key}` is not a number"),
                });
            }
        };
        if !x.is_finite() {
            return Err(KinematicsError::NotFinite {
                what: format!("{source}: `{key}`"),
            });
        }
        Ok(x)
    };
    let mut values = Values::default();
    for (key, v) in &table {
        if key == "home" {
            let toml::Value::Table(home) = v else {
                return Err(KinematicsError::Toml {
                    source_name: source.clone(),
                    line: 0,
                    message: "`home` must be a table of joint values".into(),
                });
            };
            for (k, v) in home {
                values.home.insert(k.clone(), number(k, v)?);
            }
        } else {
            values.symbols.insert(key.clone(), number(key, v)?);
        }
    }
    Ok(values)
}

impl ImportedRobot {
    /// Reads a SYMORO `.par` file with the symbol values of `options.values`
    /// (see [`ImportedRobot::from_par_str`]).
    pub fn read_par(path: &Path, options: &ImportOptions) -> Result<Self, KinematicsError> {
        let text = std::fs::read_to_string(path).map_err(|e| KinematicsError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_par_str(&text, &path.display().to_string(), options)
    }

    /// Converts the text of a SYMORO `.par` file (see the module
    /// documentation of `symoro`); `source` names it in errors and, without
    /// its directories and extension, names the robot. The symbols' values
    /// come from the TOML file `options.values`; `options.tip` names the end
    /// frame by number.
    pub fn from_par_str(
        text: &str,
        source: &str,
        options: &ImportOptions,
    ) -> Result<Self, KinematicsError> {
        let values = match &options.values {
            Some(v) => read_values(v)?,
            None => Values::default(),
        };
        let stem = Path::new(source)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("symoro")
            .to_string();
        par_from_str(text, source, &stem, &values, options)
    }
}

/// The value of `expr` with the symbols' values and `variable` (if any) at `at`.
fn evaluate(expr: &Expr, values: &Values, variable: Option<&str>, at: f64) -> f64 {
    expr.eval(&|n: &str| {
        if Some(n) == variable {
            at
        } else {
            values.symbols.get(n).copied().unwrap_or(0.0)
        }
    })
}

/// SI value of each quantity of a frame, and its joint variable (if any).
struct FrameValues {
    quantities: [f64; 6], // gamma, b, alpha, d, theta, r
    variable: Option<String>,
}

/// The assignments of a `.par` file, with its frame counts checked: what
/// every step below reads its lists from.
struct ParTable<'a> {
    table: BTreeMap<String, (usize, Vec<String>)>,
    source: &'a str,
    /// Number of links (NL), joints (NJ) and frames (NF).
    nl: usize,
    nj: usize,
    nf: usize,
}

/// The quantities of a frame, in the order of the `.par` lists.
const QUANTITY_KEYS: [&str; 6] = ["gamma", "b", "alpha", "d", "theta", "r"];

impl<'a> ParTable<'a> {
    /// Reads the assignments of `text` and checks NL, NJ and NF.
    fn new(text: &str, source: &'a str) -> Result<Self, KinematicsError> {
        let table = assignments(text, source)?;
        let count = |key: &str| -> Result<usize, KinematicsError> {
            let (line, entries) = table
                .get(key)
                .ok_or_else(|| par_error(source, 0, format!("no `{}` line", key.to_uppercase())))?;
            entries[0].parse::<usize>().map_err(|_| {
                par_error(
                    source,
                    *line,
                    format!("{} = {} is not a count", key.to_uppercase(), entries[0]),
                )
            })
        };
        let (nl, nj, nf) = (count("nl")?, count("nj")?, count("nf")?);
        if nl == 0 || nj < nl || nf != nj + (nj - nl) || nf > 10_000 {
            return Err(par_error(
                source,
                table.get("nf").map_or(0, |e| e.0),
                format!(
                    "inconsistent NL = {nl}, NJ = {nj}, NF = {nf}: NF must be NJ + (NJ - NL) = {} (one extra frame per cut joint) and NJ >= NL >= 1",
                    (2 * nj).saturating_sub(nl)
                ),
            ));
        }
        Ok(Self {
            table,
            source,
            nl,
            nj,
            nf,
        })
    }

    /// The list `key` (one entry per frame) and its line; `default` for
    /// every frame when the file has no such list.
    fn list(
        &self,
        key: &str,
        default: Option<&str>,
    ) -> Result<(usize, Vec<String>), KinematicsError> {
        let nf = self.nf;
        match self.table.get(key) {
            Some((line, entries)) => {
                if entries.len() != nf {
                    return Err(par_error(
                        self.source,
                        *line,
                        format!("`{key}` has {} entries for NF = {nf} frames", entries.len()),
                    ));
                }
                Ok((*line, entries.clone()))
            }
            None => match default {
                Some(d) => Ok((0, vec![d.to_string(); nf])),
                None => Err(par_error(self.source, 0, format!("no `{key}` list"))),
            },
        }
    }

    /// The integer entry `s` of the list `key` (on `line`).
    fn integer(&self, line: usize, key: &str, s: &str) -> Result<i64, KinematicsError> {
        s.parse::<i64>().map_err(|_| {
            par_error(
                self.source,
                line,
                format!("`{key}` entry `{s}` is not an integer"),
            )
        })
    }

    /// Every frame's quantities in SI with the symbols' values, and its
    /// joint variable; symbols without a value are reported all at once.
    fn frame_values(&self, values: &Values) -> Result<Vec<FrameValues>, KinematicsError> {
        // The structure's lists are checked before any quantity is read.
        self.list("ant", None)?;
        let (sigma_line, sigma) = self.list("sigma", None)?;
        self.list("mu", Some("0"))?;
        let lists = QUANTITY_KEYS
            .iter()
            .map(|key| self.list(key, Some("0")))
            .collect::<Result<Vec<_>, _>>()?;
        let mut missing = BTreeSet::new();
        let mut frames_values = Vec::with_capacity(self.nf);
        for (j, sigma) in sigma.iter().enumerate() {
            let s = self.integer(sigma_line, "sigma", sigma)?;
            let mut quantities = [0.0; 6];
            let mut variable = None;
            for (k, key) in QUANTITY_KEYS.iter().enumerate() {
                let (line, entries) = &lists[k];
                let holds_variable = (s == 0 && *key == "theta") || (s == 1 && *key == "r");
                let (value, var) = self.quantity(
                    (key, j, *line),
                    &entries[j],
                    values,
                    holds_variable,
                    &mut missing,
                )?;
                quantities[k] = value;
                if var.is_some() {
                    variable = var;
                }
            }
            frames_values.push(FrameValues {
                quantities,
                variable,
            });
        }
        if !missing.is_empty() {
            return Err(KinematicsError::MissingSymbols {
                source_name: self.source.to_string(),
                symbols: missing.into_iter().collect::<Vec<_>>().join(", "),
            });
        }
        Ok(frames_values)
    }

    /// The value of quantity `key` of frame `j` (0-based; given on `line`)
    /// from its expression `entry`, and its joint variable when it
    /// `holds_variable` (the theta of a revolute joint, the r of a
    /// prismatic one) and has one unknown symbol. Other unknown symbols go
    /// to `missing`.
    fn quantity(
        &self,
        (key, j, line): (&str, usize, usize),
        entry: &str,
        values: &Values,
        holds_variable: bool,
        missing: &mut BTreeSet<String>,
    ) -> Result<(f64, Option<String>), KinematicsError> {
        let source = self.source;
        let expr = parse_expr(entry)
            .map_err(|m| par_error(source, line, format!("{key} of frame {}: {m}", j + 1)))?;
        let mut symbols = BTreeSet::new();
        expr.symbols(&mut symbols);
        let unknown: Vec<String> = symbols
            .into_iter()
            .filter(|s| !values.symbols.contains_key(s))
            .collect();
        let (value, variable) = if holds_variable && unknown.len() == 1 {
            let var = unknown[0].clone();
            let at0 = evaluate(&expr, values, Some(&var), 0.0);
            let at1 = evaluate(&expr, values, Some(&var), 1.0);
            let at2 = evaluate(&expr, values, Some(&var), 2.0);
            if (at1 - at0 - 1.0).abs() > 1e-12 || (at2 - 2.0 * at1 + at0).abs() > 1e-12 {
                return Err(par_error(
                    source,
                    line,
                    format!(
                        "{key} of frame {}: the joint variable `{var}` must appear as `{var} + constant`",
                        j + 1
                    ),
                ));
            }
            (at0, Some(var))
        } else {
            missing.extend(unknown);
            (evaluate(&expr, values, None, 0.0), None)
        };
        if !value.is_finite() {
            return Err(par_error(
                source,
                line,
                format!("{key} of frame {} is not finite", j + 1),
            ));
        }
        Ok((value, variable))
    }

    /// The frames of the description, with the notes on what was
    /// assumed (joints actuated on a robot without loops, passive joints
    /// without a home value).
    fn frames(
        &self,
        frames_values: &[FrameValues],
        values: &Values,
        notes: &mut Vec<String>,
    ) -> Result<Vec<FrameDescription>, KinematicsError> {
        let source = self.source;
        let (ant_line, ant) = self.list("ant", None)?;
        let (sigma_line, sigma) = self.list("sigma", None)?;
        let (mu_line, mu) = self.list("mu", Some("0"))?;
        let mut frames = Vec::with_capacity(self.nf);
        for (j, v) in frames_values.iter().enumerate() {
            let a = self.integer(ant_line, "ant", &ant[j])?;
            if a < 0 || a as usize > self.nf {
                return Err(par_error(
                    source,
                    ant_line,
                    format!("ant of frame {} is {a}, not a frame", j + 1),
                ));
            }
            let s = self.integer(sigma_line, "sigma", &sigma[j])?;
            let joint = match s {
                0 => JointType::Revolute,
                1 => JointType::Prismatic,
                2 => JointType::Fixed,
                _ => {
                    return Err(par_error(
                        source,
                        sigma_line,
                        format!("sigma of frame {} is {s}, not 0, 1 or 2", j + 1),
                    ));
                }
            };
            let m = self.integer(mu_line, "mu", &mu[j])?;
            let mut f = FrameDescription::new(&(j + 1).to_string(), &a.to_string(), joint);
            let [gamma, b, alpha, d, theta, r] = v.quantities;
            f.gamma_deg = gamma.to_degrees();
            f.b_mm = b * 1e3;
            f.alpha_deg = alpha.to_degrees();
            f.d_mm = d * 1e3;
            f.theta_deg = theta.to_degrees();
            f.r_mm = r * 1e3;
            self.drive(&mut f, (j, m == 1), v, values, notes);
            frames.push(f);
        }
        Ok(frames)
    }

    /// Makes the joint of frame `f` (0-based number `j`; `mu_one` when its
    /// `mu` is 1) actuated or passive and gives it its home value, noting
    /// what was assumed.
    fn drive(
        &self,
        f: &mut FrameDescription,
        (j, mu_one): (usize, bool),
        v: &FrameValues,
        values: &Values,
        notes: &mut Vec<String>,
    ) {
        let joint = f.joint;
        if joint == JointType::Fixed {
            return;
        }
        let home = v
            .variable
            .as_ref()
            .and_then(|n| values.home.get(n))
            .copied();
        // The home configuration, where the loops are first assembled.
        match (home, joint) {
            (Some(h), JointType::Revolute) => f.seed_deg = h.to_degrees(),
            (Some(h), _) => f.seed_mm = h * 1e3,
            (None, _) => {}
        }
        // SYMORO reads `mu` only where there are closed loops: every joint
        // of a robot without loops is motorised, whatever its `mu`.
        let loop_free = self.nj == self.nl;
        if mu_one || loop_free {
            f.actuated = true;
            f.actuated_name = v.variable.clone();
            if !mu_one && !notes.iter().any(|n: &String| n.starts_with("mu = 0")) {
                notes.push(
                    "mu = 0 on a robot without closed loops: every joint is actuated (SYMORO uses mu only for loops)"
                        .to_string(),
                );
            }
        } else if home.is_none() {
            notes.push(format!(
                "passive joint {} has no home value: its loop is assembled from 0 (the branch nearest that configuration)",
                j + 1
            ));
        }
    }

    /// The end frame: the tip option, or the one link frame that carries
    /// no other frame.
    fn end_frame(
        &self,
        tip: Option<&String>,
        frames: &[FrameDescription],
    ) -> Result<String, KinematicsError> {
        let nf = self.nf;
        match tip {
            Some(t) => {
                if t.parse::<usize>().map_or(true, |k| k == 0 || k > nf) {
                    return Err(KinematicsError::UnknownLink {
                        source_name: self.source.to_string(),
                        what: format!("no frame `{t}` to take as the tip"),
                        known: format!("1..{nf}"),
                    });
                }
                Ok(t.clone())
            }
            None => {
                // A link that carries a cut joint or a loop's closing frame is
                // inside a loop, not at an end.
                let leaves: Vec<String> = (1..=self.nl)
                    .filter(|k| !frames.iter().any(|f| f.antecedent == k.to_string()))
                    .map(|k| k.to_string())
                    .collect();
                if leaves.len() != 1 {
                    return Err(KinematicsError::AmbiguousTip {
                        source_name: self.source.to_string(),
                        candidates: leaves.join(", "),
                    });
                }
                Ok(leaves[0].clone())
            }
        }
    }

    /// One full-constraint loop per cut joint, closed by Newton's method.
    fn loops(&self) -> Vec<LoopDescription> {
        let (nl, nj) = (self.nl, self.nj);
        (0..nj - nl)
            .map(|i| LoopDescription {
                name: format!("loop{}", i + 1),
                cut: [(nl + i + 1).to_string(), (nj + i + 1).to_string()],
                constraint: LoopConstraint::Full,
                solver: LoopSolver::Newton,
                branch: 1,
            })
            .collect()
    }
}

/// The robot of the `.par` text: its assignments read
/// ([`ParTable::new`]), each frame's quantities evaluated
/// ([`ParTable::frame_values`]), the frames ([`ParTable::frames`]), the
/// loops and the end frame, and the four-bar loops given their closed
/// form on the home configuration's branch.
fn par_from_str(
    text: &str,
    source: &str,
    name: &str,
    values: &Values,
    options: &ImportOptions,
) -> Result<ImportedRobot, KinematicsError> {
    let table = ParTable::new(text, source)?;
    let frames_values = table.frame_values(values)?;
    let mut notes = Vec::new();
    let frames = table.frames(&frames_values, values, &mut notes)?;
    let end_frame = table.end_frame(options.tip.as_ref(), &frames)?;
    let (nl, nj, nf) = (table.nl, table.nj, table.nf);
    let mut description = RobotDescription {
        name: name.to_string(),
        notes: format!(
            "Imported from the SYMORO file {source}: NL = {nl}, NJ = {nj}, NF = {nf}; frame numbers as in the file."
        ),
        end_frame: Some(end_frame),
        parameters: None,
        actuated_order: None,
        base: TransformDescription::default(),
        tool: TransformDescription::default(),
        frames,
        loops: table.loops(),
        links: Vec::new(),
    };
    four_bar_branches(&mut description, &frames_values, values, &mut notes);
    Ok(ImportedRobot {
        description,
        masses: Vec::new(),
        notes,
    })
}

/// Gives each loop that is a planar four-bar (three passive revolute
/// joints, see [`LoopSolver::FourBar`]) the closed form on the assembly
/// branch of the home configuration, so that every configuration is
/// assembled on that branch: Newton's method from the home configuration
/// alone can land on the other assembly (a parallelogram's crossed one)
/// after a move of a few tenths of a radian. Loops are taken in order (a
/// later loop may rest on an earlier one's joints); a loop that is no
/// four-bar, or a home configuration that is incomplete or that neither
/// branch reproduces, keeps Newton's method from the home values.
fn four_bar_branches(
    description: &mut RobotDescription,
    frames_values: &[FrameValues],
    values: &Values,
    notes: &mut Vec<String>,
) {
    let home_of_frame = |frame: &str| -> Option<f64> {
        let k = frame.parse::<usize>().ok()?;
        let variable = frames_values.get(k.checked_sub(1)?)?.variable.as_ref()?;
        values.home.get(variable).copied()
    };
    for i in 0..description.loops.len() {
        for branch in [1, -1] {
            let mut trial = description.clone();
            trial.loops[i].solver = LoopSolver::FourBar;
            trial.loops[i].branch = branch;
            let Ok(model) = trial.build() else {
                break;
            };
            let home_q: Option<Vec<f64>> = model
                .actuated_names()
                .iter()
                .map(|n| values.home.get(n).copied())
                .collect();
            let Some(home_q) = home_q else {
                break;
            };
            let mut data = crate::Data::new(&model);
            if crate::forward_frames(&model, &mut data, &home_q, model.nominal_params()).is_err() {
                continue;
            }
            let at_home =
                model
                    .passive_names()
                    .iter()
                    .zip(data.passive_values())
                    .all(|(frame, v)| match home_of_frame(frame) {
                        // Revolute values that differ by whole turns are one configuration.
                        Some(h) => {
                            let d =
                                (v - h + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
                            (d - std::f64::consts::PI).abs() < 1e-6
                        }
                        None => true,
                    });
            if at_home {
                *description = trial;
                notes.push(format!(
                    "loop{} is a planar four-bar: closed form on branch {branch}, the home configuration's",
                    i + 1
                ));
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_evaluate_with_pi_and_symbols() {
        let e = parse_expr("-Pi/2 + 2*(D3 - 0.5e-1)").unwrap();
        let v = e.eval(&|s: &str| if s == "D3" { 0.45 } else { f64::NAN });
        assert!((v - (-std::f64::consts::FRAC_PI_2 + 0.8)).abs() < 1e-15);
        assert!(parse_expr("1 +").is_err());
        assert!(parse_expr("(1").is_err());
        assert!(parse_expr("1 2").is_err());
    }

    #[test]
    fn comments_are_removed_but_lines_kept() {
        let s = strip_comments("a = 1 (* x\n y *)\nb = 2");
        assert_eq!(s.lines().count(), 3);
        assert!(s.contains("b = 2"));
    }
}
