//! The schema language of the long-term memory (thesis eq. 4.10, 4.11): AST, parser with
//! line/column errors, and a canonical printer whose output re-parses to the same AST.
//!
//! ```text
//! % comment to end of line
//! arms([left, right]).                      % optional: dual-arm, arm names (Sec. 4.3.4)
//! objects([water, coffee, cup]).            % optional: known objects (checked in literals)
//! schema(add(Obj), [
//!     (subtask(take,Obj), hand.free & ~Obj.added),
//!     (subtask(pour,Obj), Obj.taken)
//! ], Obj.added).
//! schema(foa8(water), [], foa8.done, foa).  % learned action: 4th argument is its kind
//! ```
//!
//! Variables start with an upper-case letter or `_`; constants with a lower-case letter or a
//! digit. A condition is `true` or a conjunction (`&`) of possibly negated (`~`) state literals,
//! each a dotted path of constants and variables (`A.O.taken`).

use std::fmt::{self, Write as _};

use crate::error::{Error, Result};

/// A source position, 1-based. Equality always holds so that ASTs compare by content only
/// (a printed-and-reparsed document has other positions but the same meaning).
#[derive(Debug, Clone, Copy, Default)]
pub struct Pos {
    /// Line, 1-based.
    pub line: usize,
    /// Column in characters, 1-based.
    pub column: usize,
}

impl PartialEq for Pos {
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}
impl Eq for Pos {}

impl std::hash::Hash for Pos {
    fn hash<H: std::hash::Hasher>(&self, _state: &mut H) {}
}

/// A term argument: a variable or a (possibly compound) term.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Arg {
    /// Capitalised variable, e.g. `Obj`.
    Var(String),
    /// Constant or compound term.
    Term(Term),
}

/// `functor(arg, ...)`; a constant has no arguments.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Term {
    /// Name, lower-case start.
    pub functor: String,
    /// Arguments (empty for a constant).
    pub args: Vec<Arg>,
}

impl Term {
    /// A constant (no arguments).
    pub fn atom(name: impl Into<String>) -> Self {
        Self { functor: name.into(), args: Vec::new() }
    }

    /// True when no variable occurs in the term.
    pub fn is_ground(&self) -> bool {
        self.args.iter().all(|a| match a {
            Arg::Var(_) => false,
            Arg::Term(t) => t.is_ground(),
        })
    }

    /// Appends the variables of the term, in order of first occurrence, to `out`.
    pub fn collect_vars<'a>(&'a self, out: &mut Vec<&'a str>) {
        for a in &self.args {
            match a {
                Arg::Var(v) => {
                    if !out.contains(&v.as_str()) {
                        out.push(v);
                    }
                }
                Arg::Term(t) => t.collect_vars(out),
            }
        }
    }

    /// Constant arguments (arity-0 terms), in order.
    pub fn constant_args(&self) -> impl Iterator<Item = &str> {
        self.args.iter().filter_map(|a| match a {
            Arg::Term(t) if t.args.is_empty() => Some(t.functor.as_str()),
            _ => None,
        })
    }

    /// Parses a term from text, e.g. a `--task` argument or a `human <subtask>` phrase.
    pub fn parse(text: &str) -> Result<Self> {
        let mut p = Parser::new(text)?;
        let t = p.term()?;
        p.expect_eof()?;
        Ok(t)
    }
}

impl fmt::Display for Term {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.functor)?;
        if !self.args.is_empty() {
            f.write_char('(')?;
            for (i, a) in self.args.iter().enumerate() {
                if i > 0 {
                    f.write_char(',')?;
                }
                match a {
                    Arg::Var(v) => f.write_str(v)?,
                    Arg::Term(t) => write!(f, "{t}")?,
                }
            }
            f.write_char(')')?;
        }
        Ok(())
    }
}

/// One segment of a literal path.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Seg {
    /// Constant, e.g. `hand`.
    Atom(String),
    /// Variable, e.g. `Obj`.
    Var(String),
}

/// A possibly negated state literal, e.g. `~Obj.added`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Literal {
    /// `~` in front.
    pub negated: bool,
    /// Dotted path, at least one segment.
    pub path: Vec<Seg>,
    /// Where it was written.
    pub pos: Pos,
}

impl fmt::Display for Literal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.negated {
            f.write_char('~')?;
        }
        for (i, s) in self.path.iter().enumerate() {
            if i > 0 {
                f.write_char('.')?;
            }
            match s {
                Seg::Atom(a) | Seg::Var(a) => f.write_str(a)?,
            }
        }
        Ok(())
    }
}

/// A conjunction of literals; empty means `true`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct Cond {
    /// Literals, all of which must hold.
    pub literals: Vec<Literal>,
}

impl Cond {
    /// The always-true condition.
    pub fn truth() -> Self {
        Self::default()
    }

    /// Variables used, appended to `out` in first-occurrence order.
    pub fn collect_vars<'a>(&'a self, out: &mut Vec<&'a str>) {
        for l in &self.literals {
            for s in &l.path {
                if let Seg::Var(v) = s
                    && !out.contains(&v.as_str())
                {
                    out.push(v);
                }
            }
        }
    }
}

impl fmt::Display for Cond {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.literals.is_empty() {
            return f.write_str("true");
        }
        for (i, l) in self.literals.iter().enumerate() {
            if i > 0 {
                f.write_str(" & ")?;
            }
            write!(f, "{l}")?;
        }
        Ok(())
    }
}

/// Kind of a learned atomic action (thesis Sec. 4.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionKind {
    /// Far-object action (linear DS).
    Foa,
    /// Near-object action (DMP).
    Noa,
    /// Gripper open/close.
    Gripper,
}

impl ActionKind {
    /// Keyword used in the schema file.
    pub fn keyword(self) -> &'static str {
        match self {
            Self::Foa => "foa",
            Self::Noa => "noa",
            Self::Gripper => "gripper",
        }
    }

    fn from_keyword(s: &str) -> Option<Self> {
        match s {
            "foa" => Some(Self::Foa),
            "noa" => Some(Self::Noa),
            "gripper" => Some(Self::Gripper),
            _ => None,
        }
    }
}

/// One `(sub-behaviour, releaser)` pair of a schema's list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// Sub-behaviour term.
    pub term: Term,
    /// Enabling condition.
    pub releaser: Cond,
    /// Where the entry starts.
    pub pos: Pos,
}

/// `schema(m, l, p[, kind]).`
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// m: the behaviour this schema decomposes.
    pub head: Term,
    /// l: sub-behaviours with releasers.
    pub list: Vec<Entry>,
    /// p: post-condition.
    pub post: Cond,
    /// Present for learned atomic actions.
    pub kind: Option<ActionKind>,
    /// Where `schema` was written.
    pub pos: Pos,
}

/// A top-level clause.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Clause {
    /// `schema(...)`.
    Schema(Schema),
    /// `arms([...]).`
    Arms { names: Vec<String>, pos: Pos },
    /// `objects([...]).`
    Objects { names: Vec<String>, pos: Pos },
}

/// A clause with the comment lines written just before it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item {
    /// Comment texts (without the leading `%` and one space).
    pub comments: Vec<String>,
    /// The clause.
    pub clause: Clause,
}

/// A whole schema file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Document {
    /// Clauses in file order.
    pub items: Vec<Item>,
    /// Comments after the last clause.
    pub trailing_comments: Vec<String>,
}

impl Document {
    /// Parses a whole file.
    pub fn parse(text: &str) -> Result<Self> {
        Parser::new(text)?.document()
    }

    /// Canonical text; `Document::parse(&d.print()) == Ok(d)`.
    pub fn print(&self) -> String {
        let mut s = String::new();
        for it in &self.items {
            for c in &it.comments {
                push_comment(&mut s, c);
            }
            print_clause(&mut s, &it.clause);
        }
        for c in &self.trailing_comments {
            push_comment(&mut s, c);
        }
        s
    }
}

fn push_comment(s: &mut String, c: &str) {
    if c.is_empty() {
        s.push_str("%\n");
    } else {
        let _ = writeln!(s, "% {c}");
    }
}

fn print_names(s: &mut String, kw: &str, names: &[String]) {
    let _ = writeln!(s, "{kw}([{}]).", names.join(", "));
}

/// Prints one clause in canonical form (ends with a newline).
pub fn print_clause(s: &mut String, c: &Clause) {
    match c {
        Clause::Arms { names, .. } => print_names(s, "arms", names),
        Clause::Objects { names, .. } => print_names(s, "objects", names),
        Clause::Schema(sc) => {
            let _ = write!(s, "schema({}, [", sc.head);
            if !sc.list.is_empty() {
                s.push('\n');
                for (i, e) in sc.list.iter().enumerate() {
                    let _ = write!(s, "    ({}, {})", e.term, e.releaser);
                    s.push_str(if i + 1 < sc.list.len() { ",\n" } else { "\n" });
                }
            }
            let _ = write!(s, "], {}", sc.post);
            if let Some(k) = sc.kind {
                let _ = write!(s, ", {}", k.keyword());
            }
            s.push_str(").\n");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Lexer

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Atom(String),
    Var(String),
    LParen,
    RParen,
    LBracket,
    RBracket,
    Comma,
    Dot,
    Amp,
    Tilde,
    Comment(String),
    Eof,
}

impl fmt::Display for Tok {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Atom(a) => write!(f, "name '{a}'"),
            Tok::Var(v) => write!(f, "variable '{v}'"),
            Tok::LParen => f.write_str("'('"),
            Tok::RParen => f.write_str("')'"),
            Tok::LBracket => f.write_str("'['"),
            Tok::RBracket => f.write_str("']'"),
            Tok::Comma => f.write_str("','"),
            Tok::Dot => f.write_str("'.'"),
            Tok::Amp => f.write_str("'&'"),
            Tok::Tilde => f.write_str("'~'"),
            Tok::Comment(_) => f.write_str("comment"),
            Tok::Eof => f.write_str("end of input"),
        }
    }
}

fn lex(text: &str) -> Result<Vec<(Tok, Pos)>> {
    let mut out = Vec::new();
    let mut it = text.chars().peekable();
    let (mut line, mut col) = (1usize, 1usize);
    while let Some(&c) = it.peek() {
        let pos = Pos { line, column: col };
        let mut bump = |it: &mut std::iter::Peekable<std::str::Chars<'_>>| {
            let ch = it.next();
            if ch == Some('\n') {
                line += 1;
                col = 1;
            } else {
                col += 1;
            }
            ch
        };
        if c.is_whitespace() {
            bump(&mut it);
            continue;
        }
        if c == '%' {
            bump(&mut it);
            let mut body = String::new();
            while let Some(&d) = it.peek() {
                if d == '\n' {
                    break;
                }
                body.push(d);
                bump(&mut it);
            }
            let body = body.strip_prefix(' ').unwrap_or(&body).trim_end().to_owned();
            out.push((Tok::Comment(body), pos));
            continue;
        }
        let single = match c {
            '(' => Some(Tok::LParen),
            ')' => Some(Tok::RParen),
            '[' => Some(Tok::LBracket),
            ']' => Some(Tok::RBracket),
            ',' => Some(Tok::Comma),
            '.' => Some(Tok::Dot),
            '&' => Some(Tok::Amp),
            '~' => Some(Tok::Tilde),
            _ => None,
        };
        if let Some(t) = single {
            bump(&mut it);
            out.push((t, pos));
            continue;
        }
        if c.is_alphanumeric() || c == '_' {
            let mut word = String::new();
            while let Some(&d) = it.peek() {
                if d.is_alphanumeric() || d == '_' {
                    word.push(d);
                    bump(&mut it);
                } else {
                    break;
                }
            }
            let is_var = word.starts_with(|ch: char| ch.is_uppercase() || ch == '_');
            out.push((if is_var { Tok::Var(word) } else { Tok::Atom(word) }, pos));
            continue;
        }
        return Err(Error::Syntax {
            line: pos.line,
            column: pos.column,
            message: format!("unexpected character {c:?}"),
        });
    }
    out.push((Tok::Eof, Pos { line, column: col }));
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Parser

/// Deepest term nesting accepted (guards the recursive parser against hostile input).
const MAX_NESTING: usize = 32;

struct Parser {
    toks: Vec<(Tok, Pos)>,
    i: usize,
    comments: Vec<String>,
    depth: usize,
}

impl Parser {
    fn new(text: &str) -> Result<Self> {
        Ok(Self { toks: lex(text)?, i: 0, comments: Vec::new(), depth: 0 })
    }

    /// Current token, collecting comments that precede it.
    fn peek(&mut self) -> &(Tok, Pos) {
        while let (Tok::Comment(c), _) = &self.toks[self.i] {
            self.comments.push(c.clone());
            self.i += 1;
        }
        &self.toks[self.i]
    }

    fn peek2(&mut self) -> &Tok {
        self.peek();
        let mut j = self.i + 1;
        while j < self.toks.len() {
            if !matches!(self.toks[j].0, Tok::Comment(_)) {
                return &self.toks[j].0;
            }
            j += 1;
        }
        &Tok::Eof
    }

    fn next(&mut self) -> (Tok, Pos) {
        let t = self.peek().clone();
        if !matches!(t.0, Tok::Eof) {
            self.i += 1;
        }
        t
    }

    fn err<T>(&self, pos: Pos, message: String) -> Result<T> {
        Err(Error::Syntax { line: pos.line, column: pos.column, message })
    }

    fn expect(&mut self, want: Tok, what: &str) -> Result<Pos> {
        let (t, pos) = self.next();
        if t == want { Ok(pos) } else { self.err(pos, format!("expected {what} but found {t}")) }
    }

    fn expect_eof(&mut self) -> Result<()> {
        let (t, pos) = self.next();
        if t == Tok::Eof { Ok(()) } else { self.err(pos, format!("expected end of input but found {t}")) }
    }

    fn document(&mut self) -> Result<Document> {
        let mut doc = Document::default();
        loop {
            let (t, pos) = self.peek().clone();
            let comments = std::mem::take(&mut self.comments);
            match t {
                Tok::Eof => {
                    doc.trailing_comments = comments;
                    return Ok(doc);
                }
                Tok::Atom(ref a) => {
                    let clause = match a.as_str() {
                        "schema" => Clause::Schema(self.schema()?),
                        "arms" => {
                            let names = self.name_list("arms")?;
                            Clause::Arms { names, pos }
                        }
                        "objects" => {
                            let names = self.name_list("objects")?;
                            Clause::Objects { names, pos }
                        }
                        other => {
                            return self.err(
                                pos,
                                format!("expected 'schema', 'arms' or 'objects' but found name '{other}'"),
                            );
                        }
                    };
                    self.expect(Tok::Dot, "'.' at the end of the clause")?;
                    doc.items.push(Item { comments, clause });
                }
                other => {
                    return self.err(pos, format!("expected 'schema', 'arms' or 'objects' but found {other}"));
                }
            }
        }
    }

    fn name_list(&mut self, _kw: &str) -> Result<Vec<String>> {
        self.next();
        self.expect(Tok::LParen, "'('")?;
        self.expect(Tok::LBracket, "'['")?;
        let mut names = Vec::new();
        if self.peek().0 != Tok::RBracket {
            loop {
                match self.next() {
                    (Tok::Atom(a), _) => names.push(a),
                    (t, pos) => return self.err(pos, format!("expected a lower-case name but found {t}")),
                }
                match self.next() {
                    (Tok::Comma, _) => continue,
                    (Tok::RBracket, _) => break,
                    (t, pos) => return self.err(pos, format!("expected ',' or ']' but found {t}")),
                }
            }
        } else {
            self.next();
        }
        self.expect(Tok::RParen, "')'")?;
        Ok(names)
    }

    fn schema(&mut self) -> Result<Schema> {
        let (_, pos) = self.next();
        self.expect(Tok::LParen, "'(' after 'schema'")?;
        let head = self.term()?;
        self.expect(Tok::Comma, "',' after the schema head")?;
        self.expect(Tok::LBracket, "'[' opening the sub-behaviour list")?;
        let mut list = Vec::new();
        if self.peek().0 == Tok::RBracket {
            self.next();
        } else {
            loop {
                let epos = self.expect(Tok::LParen, "'(' opening a (behaviour, releaser) pair")?;
                let term = self.term()?;
                self.expect(Tok::Comma, "',' between behaviour and releaser")?;
                let releaser = self.cond()?;
                self.expect(Tok::RParen, "')' closing the (behaviour, releaser) pair")?;
                list.push(Entry { term, releaser, pos: epos });
                match self.next() {
                    (Tok::Comma, _) => continue,
                    (Tok::RBracket, _) => break,
                    (t, p) => return self.err(p, format!("expected ',' or ']' in the sub-behaviour list but found {t}")),
                }
            }
        }
        self.expect(Tok::Comma, "',' before the post-condition")?;
        let post = self.cond()?;
        let kind = if self.peek().0 == Tok::Comma {
            self.next();
            match self.next() {
                (Tok::Atom(a), p) => match ActionKind::from_keyword(&a) {
                    Some(k) => Some(k),
                    None => return self.err(p, format!("expected action kind foa, noa or gripper but found name '{a}'")),
                },
                (t, p) => return self.err(p, format!("expected action kind foa, noa or gripper but found {t}")),
            }
        } else {
            None
        };
        self.expect(Tok::RParen, "')' closing the schema")?;
        Ok(Schema { head, list, post, kind, pos })
    }

    fn term(&mut self) -> Result<Term> {
        self.depth += 1;
        let t = self.term_inner();
        self.depth -= 1;
        t
    }

    fn term_inner(&mut self) -> Result<Term> {
        if self.depth > MAX_NESTING {
            let pos = self.peek().1;
            return self.err(pos, format!("terms nested deeper than {MAX_NESTING}"));
        }
        let functor = match self.next() {
            (Tok::Atom(a), _) => a,
            (t, p) => return self.err(p, format!("expected a behaviour name (lower-case) but found {t}")),
        };
        let mut args = Vec::new();
        if self.peek().0 == Tok::LParen {
            self.next();
            loop {
                let arg = match self.peek().0.clone() {
                    Tok::Var(v) => {
                        self.next();
                        Arg::Var(v)
                    }
                    _ => Arg::Term(self.term()?),
                };
                args.push(arg);
                match self.next() {
                    (Tok::Comma, _) => continue,
                    (Tok::RParen, _) => break,
                    (t, p) => return self.err(p, format!("expected ',' or ')' in the arguments of '{functor}' but found {t}")),
                }
            }
        }
        Ok(Term { functor, args })
    }

    fn cond(&mut self) -> Result<Cond> {
        if let Tok::Atom(a) = &self.peek().0
            && a == "true"
            && *self.peek2() != Tok::Dot
        {
            let (_, pos) = self.next();
            if self.peek().0 == Tok::Amp {
                return self.err(pos, "'true' cannot be combined with other literals".into());
            }
            return Ok(Cond::truth());
        }
        let mut literals = vec![self.literal()?];
        while self.peek().0 == Tok::Amp {
            self.next();
            literals.push(self.literal()?);
        }
        Ok(Cond { literals })
    }

    fn literal(&mut self) -> Result<Literal> {
        let pos = self.peek().1;
        let negated = if self.peek().0 == Tok::Tilde {
            self.next();
            true
        } else {
            false
        };
        let mut path = vec![self.seg()?];
        while self.peek().0 == Tok::Dot && matches!(self.peek2(), Tok::Atom(_) | Tok::Var(_)) {
            self.next();
            path.push(self.seg()?);
        }
        if path.len() == 1 && path[0] == Seg::Atom("true".into()) {
            return self.err(pos, "'true' cannot be combined with other literals".into());
        }
        Ok(Literal { negated, path, pos })
    }

    fn seg(&mut self) -> Result<Seg> {
        match self.next() {
            (Tok::Atom(a), _) => Ok(Seg::Atom(a)),
            (Tok::Var(v), _) => Ok(Seg::Var(v)),
            (t, p) => self.err(p, format!("expected a state literal such as hand.free but found {t}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ADD: &str = "% the add task\nschema(add(Obj), [(subtask(take,Obj), hand.free), (subtask(pour,Obj), Obj.taken)], Obj.used).\n";

    #[test]
    fn parses_thesis_notation() {
        let d = Document::parse(ADD).expect("parse");
        assert_eq!(d.items.len(), 1);
        assert_eq!(d.items[0].comments, vec!["the add task".to_owned()]);
        let Clause::Schema(s) = &d.items[0].clause else { panic!("not a schema") };
        assert_eq!(s.head.to_string(), "add(Obj)");
        assert_eq!(s.list.len(), 2);
        assert_eq!(s.list[1].releaser.to_string(), "Obj.taken");
        assert_eq!(s.post.to_string(), "Obj.used");
    }

    #[test]
    fn print_reparses_identically() {
        let src = "arms([left, right]).\nschema(add(A,O), [(subtask(A,take,O), A.hand.free & ~O.used), (x, true)], O.used).\nschema(foa1(water), [], foa1.done, foa).\n% end\n";
        let d = Document::parse(src).expect("parse");
        let p = d.print();
        let d2 = Document::parse(&p).expect("reparse");
        assert_eq!(d, d2);
        assert_eq!(p, d2.print());
    }

    #[test]
    fn syntax_error_has_line_and_column() {
        let src = "schema(a, [], true).\nschema(b, [(c, true) (d, true)], true).\n";
        match Document::parse(src) {
            Err(Error::Syntax { line, column, message }) => {
                assert_eq!((line, column), (2, 22), "{message}");
                assert!(message.contains("expected ',' or ']'"), "{message}");
            }
            other => panic!("expected a syntax error, got {other:?}"),
        }
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let deep = format!("{}x{}", "a(".repeat(100_000), ")".repeat(100_000));
        assert!(matches!(Term::parse(&deep), Err(Error::Syntax { line: 1, .. })));
        assert!(Term::parse(&format!("{}x{}", "a(".repeat(10), ")".repeat(10))).is_ok());
    }

    #[test]
    fn bad_character_and_missing_dot() {
        assert!(matches!(Document::parse("schema(a, [], x$y)."), Err(Error::Syntax { line: 1, column: 16, .. })));
        assert!(matches!(Document::parse("schema(a, [], true)"), Err(Error::Syntax { line: 1, column: 20, .. })));
    }
}
