//! Long-term memory (thesis Sec. 4.3.2): the validated set of schemas, retrieval of the most
//! specific schema for a behaviour, learning updates (Algorithm 4, lines 11–12) and atomic
//! save/load.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Error, Result};
use crate::schema::{ActionKind, Arg, Clause, Cond, Document, Entry, Item, Literal, Pos, Schema, Seg, Term};

/// Index of a schema in the LTM.
pub type SchemaId = usize;

/// Variable bindings from matching a schema head against a ground behaviour.
pub type Bindings = Vec<(String, Term)>;

/// Names that may appear as non-final segments of a literal besides objects and arms.
const BUILTIN_NAMES: [&str; 3] = ["hand", "gripper", "arm"];

/// The long-term memory: a validated schema document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ltm {
    doc: Document,
    arms: Vec<String>,
    objects: Option<Vec<String>>,
}

impl Ltm {
    /// Parses and validates schema text (syntax, unbound variables, unknown objects, unknown
    /// sub-behaviours, duplicates, cycles).
    pub fn parse(text: &str) -> Result<Self> {
        Self::from_document(Document::parse(text)?)
    }

    /// Validates a parsed document.
    pub fn from_document(doc: Document) -> Result<Self> {
        let mut arms = Vec::new();
        let mut objects: Option<Vec<String>> = None;
        for it in &doc.items {
            match &it.clause {
                Clause::Arms { names, .. } => arms.extend(names.iter().cloned()),
                Clause::Objects { names, .. } => objects.get_or_insert_with(Vec::new).extend(names.iter().cloned()),
                Clause::Schema(_) => {}
            }
        }
        let ltm = Self { doc, arms, objects };
        ltm.validate()?;
        Ok(ltm)
    }

    /// Reads and validates a schema file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { op: "reading", path: path.to_owned(), source })?;
        Self::parse(&text)
    }

    /// Writes the canonical text atomically and durably ([`cowork_store::write_atomic`]:
    /// temporary file, fsync, rename, directory fsync). A crash leaves the old or the new file.
    pub fn save(&self, path: &Path) -> Result<()> {
        cowork_store::write_atomic(path, self.to_text().as_bytes())
            .map_err(|source| Error::Io { op: "saving", path: path.to_owned(), source })
    }

    /// Canonical schema text (what `save` writes).
    pub fn to_text(&self) -> String {
        self.doc.print()
    }

    /// The underlying document.
    pub fn document(&self) -> &Document {
        &self.doc
    }

    /// Arm names from `arms([...])`; empty for a single-arm robot.
    pub fn arms(&self) -> &[String] {
        &self.arms
    }

    /// Objects from `objects([...])`, if declared.
    pub fn declared_objects(&self) -> Option<&[String]> {
        self.objects.as_deref()
    }

    /// True when `name` is a declared object (always true when no objects are declared).
    pub fn is_object(&self, name: &str) -> bool {
        self.objects.as_ref().is_none_or(|o| o.iter().any(|x| x == name))
    }

    /// The schema with this id. Panics on an id not obtained from this LTM.
    pub fn schema(&self, id: SchemaId) -> &Schema {
        match &self.doc.items[id].clause {
            Clause::Schema(s) => s,
            _ => unreachable!("SchemaId always indexes a schema clause"),
        }
    }

    /// All schemas with their ids.
    pub fn schemas(&self) -> impl Iterator<Item = (SchemaId, &Schema)> {
        self.doc.items.iter().enumerate().filter_map(|(i, it)| match &it.clause {
            Clause::Schema(s) => Some((i, s)),
            _ => None,
        })
    }

    /// The most specific schema whose head matches the ground behaviour (fewest head
    /// variables; the first one on a tie), with the bindings of its head variables.
    pub fn retrieve(&self, ground: &Term) -> Option<(SchemaId, Bindings)> {
        let mut best: Option<(usize, SchemaId, Bindings)> = None;
        for (id, s) in self.schemas() {
            let mut b = Bindings::new();
            if match_term(&s.head, ground, &mut b) {
                let nvars = b.len();
                if best.as_ref().is_none_or(|(n, _, _)| nvars < *n) {
                    best = Some((nvars, id, b));
                }
            }
        }
        best.map(|(_, id, b)| (id, b))
    }

    /// True when an action schema with this functor exists.
    pub fn has_action(&self, functor: &str) -> bool {
        self.schemas().any(|(_, s)| s.kind.is_some() && s.head.functor == functor)
    }

    /// Algorithm 4, lines 11–12: stores a learned action under the ground subtask. A subtask
    /// still described by a generic schema (e.g. `subtask(take,Obj)`) gets its own specialised
    /// schema (e.g. `subtask(take,water)` with the instantiated post-condition), so other
    /// instances of the generic schema stay open. Returns the id of the subtask's schema.
    pub fn learn_action(
        &mut self,
        subtask: &Term,
        subtask_post: &Cond,
        action: &Term,
        kind: ActionKind,
        releaser: &Cond,
    ) -> SchemaId {
        let existing = self.schemas().find(|(_, s)| s.kind.is_none() && &s.head == subtask).map(|(i, _)| i);
        let sid = match existing {
            Some(i) => i,
            None => {
                self.doc.items.push(Item {
                    comments: vec![format!("learned from demonstration: {subtask}")],
                    clause: Clause::Schema(Schema {
                        head: subtask.clone(),
                        list: Vec::new(),
                        post: subtask_post.clone(),
                        kind: None,
                        pos: Pos::default(),
                    }),
                });
                self.doc.items.len() - 1
            }
        };
        if let Clause::Schema(s) = &mut self.doc.items[sid].clause {
            s.list.push(Entry { term: action.clone(), releaser: releaser.clone(), pos: Pos::default() });
        }
        self.doc.items.push(Item {
            comments: Vec::new(),
            clause: Clause::Schema(Schema {
                head: action.clone(),
                list: Vec::new(),
                post: done_cond(&action.functor),
                kind: Some(kind),
                pos: Pos::default(),
            }),
        });
        sid
    }

    /// Empties the learned action list of the specialised schema of `subtask` (it stays,
    /// open, for another demonstration). The action schemas themselves stay, unreferenced, so
    /// every [`SchemaId`] handed out stays valid. Returns how many entries were removed.
    pub fn forget_subtask_actions(&mut self, subtask: &Term) -> usize {
        let Some(sid) = self.schemas().find(|(_, s)| s.kind.is_none() && &s.head == subtask).map(|(i, _)| i) else { return 0 };
        let item = &mut self.doc.items[sid];
        let Clause::Schema(s) = &mut item.clause else { return 0 };
        let n = s.list.len();
        s.list.clear();
        if n > 0 {
            item.comments.push(format!("{n} actions of an unfinished demonstration forgotten"));
        }
        n
    }

    fn validate(&self) -> Result<()> {
        let mut heads: HashMap<String, usize> = HashMap::new();
        let action_functors: Vec<&str> =
            self.schemas().filter(|(_, s)| s.kind.is_some()).map(|(_, s)| s.head.functor.as_str()).collect();
        for (_, s) in self.schemas() {
            let key = s.head.to_string();
            if let Some(first) = heads.get(&key) {
                return Err(Error::DuplicateSchema { head: key, line: s.pos.line, first_line: *first });
            }
            heads.insert(key, s.pos.line);
            if s.kind.is_some() && !s.list.is_empty() {
                return Err(Error::ActionWithChildren { head: s.head.to_string(), line: s.pos.line });
            }
            self.check_variables(s)?;
            if let Some(objs) = &self.objects {
                for l in s.list.iter().flat_map(|e| e.releaser.literals.iter()).chain(s.post.literals.iter()) {
                    self.check_literal_names(l, objs, &action_functors)?;
                }
            }
            for e in &s.list {
                if !self.schemas().any(|(_, t)| unifiable(&e.term, &t.head)) {
                    return Err(Error::UnknownBehaviour {
                        behaviour: e.term.to_string(),
                        line: e.pos.line,
                        column: e.pos.column,
                    });
                }
            }
        }
        self.check_cycles()
    }

    fn check_variables(&self, s: &Schema) -> Result<()> {
        let mut head_vars = Vec::new();
        s.head.collect_vars(&mut head_vars);
        let unbound = |variable: &str, pos: Pos, hint: &str| Error::UnboundVariable {
            schema: s.head.to_string(),
            variable: variable.to_owned(),
            line: pos.line,
            column: pos.column,
            hint: hint.to_owned(),
        };
        for l in &s.post.literals {
            for seg in &l.path {
                if let Seg::Var(v) = seg
                    && !head_vars.contains(&v.as_str())
                {
                    return Err(unbound(v, l.pos, " (post-condition variables must appear in the head)"));
                }
            }
        }
        for e in &s.list {
            let mut term_vars = Vec::new();
            e.term.collect_vars(&mut term_vars);
            for v in &term_vars {
                if !head_vars.contains(v) && self.arms.is_empty() {
                    return Err(unbound(v, e.pos, " (only arm variables may be free, and this LTM declares no arms)"));
                }
            }
            for l in &e.releaser.literals {
                for seg in &l.path {
                    if let Seg::Var(v) = seg
                        && !head_vars.contains(&v.as_str())
                        && !term_vars.contains(&v.as_str())
                    {
                        return Err(unbound(v, l.pos, " (releaser variables must appear in the head or the sub-behaviour)"));
                    }
                }
            }
        }
        Ok(())
    }

    fn check_literal_names(&self, l: &Literal, objs: &[String], actions: &[&str]) -> Result<()> {
        let n = l.path.len();
        for seg in &l.path[..n.saturating_sub(1)] {
            if let Seg::Atom(a) = seg
                && !objs.contains(a)
                && !self.arms.contains(a)
                && !BUILTIN_NAMES.contains(&a.as_str())
                && !actions.contains(&a.as_str())
            {
                return Err(Error::UnknownObject {
                    name: a.clone(),
                    line: l.pos.line,
                    column: l.pos.column,
                    declared: objs.join(", "),
                });
            }
        }
        Ok(())
    }

    /// Depth-first search over "sub-behaviour unifies with head" edges.
    fn check_cycles(&self) -> Result<()> {
        let ids: Vec<SchemaId> = self.schemas().map(|(i, _)| i).collect();
        let mut edges: HashMap<SchemaId, Vec<SchemaId>> = HashMap::new();
        for &i in &ids {
            let s = self.schema(i);
            let mut out = Vec::new();
            for e in &s.list {
                for &j in &ids {
                    if unifiable(&e.term, &self.schema(j).head) && !out.contains(&j) {
                        out.push(j);
                    }
                }
            }
            edges.insert(i, out);
        }
        // 0 = unvisited, 1 = on stack, 2 = done.
        let mut mark: HashMap<SchemaId, u8> = ids.iter().map(|&i| (i, 0)).collect();
        let mut stack: Vec<SchemaId> = Vec::new();
        fn dfs(
            i: SchemaId,
            edges: &HashMap<SchemaId, Vec<SchemaId>>,
            mark: &mut HashMap<SchemaId, u8>,
            stack: &mut Vec<SchemaId>,
        ) -> Option<Vec<SchemaId>> {
            mark.insert(i, 1);
            stack.push(i);
            for &j in edges.get(&i).map(Vec::as_slice).unwrap_or(&[]) {
                match mark.get(&j).copied().unwrap_or(0) {
                    1 => {
                        let start = stack.iter().position(|&x| x == j).unwrap_or(0);
                        let mut cyc = stack[start..].to_vec();
                        cyc.push(j);
                        return Some(cyc);
                    }
                    0 => {
                        if let Some(c) = dfs(j, edges, mark, stack) {
                            return Some(c);
                        }
                    }
                    _ => {}
                }
            }
            stack.pop();
            mark.insert(i, 2);
            None
        }
        for &i in &ids {
            if mark.get(&i).copied() == Some(0)
                && let Some(c) = dfs(i, &edges, &mut mark, &mut stack)
            {
                return Err(Error::CyclicSchema { cycle: c.iter().map(|&k| self.schema(k).head.to_string()).collect() });
            }
        }
        Ok(())
    }
}

/// `functor.done`, the post-condition of a learned action (Algorithm 4, line 9).
pub fn done_cond(functor: &str) -> Cond {
    Cond {
        literals: vec![Literal {
            negated: false,
            path: vec![Seg::Atom(functor.to_owned()), Seg::Atom("done".into())],
            pos: Pos::default(),
        }],
    }
}

/// One-way matching of a pattern (with variables) against a ground term.
pub fn match_term(pattern: &Term, ground: &Term, b: &mut Bindings) -> bool {
    if pattern.functor != ground.functor || pattern.args.len() != ground.args.len() {
        return false;
    }
    for (p, g) in pattern.args.iter().zip(&ground.args) {
        let Arg::Term(gt) = g else { return false };
        match p {
            Arg::Var(v) => match b.iter().find(|(n, _)| n == v) {
                Some((_, bound)) => {
                    if bound != gt {
                        return false;
                    }
                }
                None => b.push((v.clone(), gt.clone())),
            },
            Arg::Term(pt) => {
                if !match_term(pt, gt, b) {
                    return false;
                }
            }
        }
    }
    true
}

/// Replaces bound variables; unbound ones stay.
pub fn substitute(t: &Term, b: &Bindings) -> Term {
    Term {
        functor: t.functor.clone(),
        args: t
            .args
            .iter()
            .map(|a| match a {
                Arg::Var(v) => match b.iter().find(|(n, _)| n == v) {
                    Some((_, t)) => Arg::Term(t.clone()),
                    None => a.clone(),
                },
                Arg::Term(t) => Arg::Term(substitute(t, b)),
            })
            .collect(),
    }
}

/// Instantiates a condition; `None` if a variable is unbound.
pub fn substitute_cond(c: &Cond, b: &Bindings) -> Option<Cond> {
    let mut out = Cond::default();
    for l in &c.literals {
        let mut path = Vec::with_capacity(l.path.len());
        for s in &l.path {
            path.push(match s {
                Seg::Atom(a) => Seg::Atom(a.clone()),
                Seg::Var(v) => Seg::Atom(b.iter().find(|(n, _)| n == v)?.1.to_string()),
            });
        }
        out.literals.push(Literal { negated: l.negated, path, pos: l.pos });
    }
    Some(out)
}

/// Two-way unification of two patterns whose variables are renamed apart.
fn unifiable(a: &Term, b: &Term) -> bool {
    let mut subst: HashMap<String, Arg> = HashMap::new();
    let ra = rename(a, "L");
    let rb = rename(b, "R");
    unify(&Arg::Term(ra), &Arg::Term(rb), &mut subst)
}

fn rename(t: &Term, tag: &str) -> Term {
    Term {
        functor: t.functor.clone(),
        args: t
            .args
            .iter()
            .map(|a| match a {
                Arg::Var(v) => Arg::Var(format!("{v}#{tag}")),
                Arg::Term(t) => Arg::Term(rename(t, tag)),
            })
            .collect(),
    }
}

fn walk(a: &Arg, s: &HashMap<String, Arg>) -> Arg {
    let mut cur = a.clone();
    while let Arg::Var(v) = &cur {
        match s.get(v) {
            Some(n) => cur = n.clone(),
            None => break,
        }
    }
    cur
}

fn unify(a: &Arg, b: &Arg, s: &mut HashMap<String, Arg>) -> bool {
    let (a, b) = (walk(a, s), walk(b, s));
    match (&a, &b) {
        (Arg::Var(x), Arg::Var(y)) if x == y => true,
        (Arg::Var(x), _) => {
            s.insert(x.clone(), b.clone());
            true
        }
        (_, Arg::Var(y)) => {
            s.insert(y.clone(), a.clone());
            true
        }
        (Arg::Term(x), Arg::Term(y)) => {
            x.functor == y.functor
                && x.args.len() == y.args.len()
                && x.args.iter().zip(&y.args).all(|(p, q)| unify(p, q, s))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = "objects([water, coffee]).\n\
        schema(add(Obj), [(subtask(take,Obj), hand.free), (subtask(pour,Obj), Obj.taken)], Obj.used).\n\
        schema(subtask(take,Obj), [], Obj.taken).\n\
        schema(subtask(pour,Obj), [], Obj.used).\n";

    #[test]
    fn retrieves_most_specific() {
        let mut ltm = Ltm::parse(BASE).expect("valid");
        let water = Term::parse("subtask(take,water)").expect("term");
        let (id, b) = ltm.retrieve(&water).expect("generic matches");
        assert_eq!(ltm.schema(id).head.to_string(), "subtask(take,Obj)");
        assert_eq!(b[0].1.to_string(), "water");
        let post = Cond::default();
        let foa = Term::parse("foa1(water)").expect("term");
        let sid = ltm.learn_action(&water, &post, &foa, ActionKind::Foa, &Cond::truth());
        let (id2, b2) = ltm.retrieve(&water).expect("specialised");
        assert_eq!(id2, sid);
        assert!(b2.is_empty());
        // The generic one still serves other objects.
        let (id3, _) = ltm.retrieve(&Term::parse("subtask(take,coffee)").expect("term")).expect("generic");
        assert_eq!(id3, id);
        assert!(ltm.has_action("foa1"));
        // The learned LTM re-validates and round-trips.
        let again = Ltm::parse(&ltm.to_text()).expect("reparse");
        assert_eq!(again.to_text(), ltm.to_text());
    }

    #[test]
    fn rejects_unbound_variable() {
        let e = Ltm::parse("schema(a(X), [], Y.done).").expect_err("unbound");
        assert!(matches!(e, Error::UnboundVariable { ref variable, line: 1, column: 18, .. } if variable == "Y"), "{e}");
        let e = Ltm::parse("schema(a, [(b(X), true)], true).\nschema(b(Y), [], Y.done).").expect_err("unbound");
        assert!(matches!(e, Error::UnboundVariable { ref variable, line: 1, .. } if variable == "X"), "{e}");
    }

    #[test]
    fn rejects_cycle() {
        let e = Ltm::parse("schema(a(X), [(b(X), true)], X.a).\nschema(b(Y), [(a(Y), true)], Y.b).").expect_err("cycle");
        match e {
            Error::CyclicSchema { cycle } => assert_eq!(cycle, vec!["a(X)", "b(Y)", "a(X)"]),
            other => panic!("{other}"),
        }
    }

    #[test]
    fn rejects_unknown_object_and_behaviour() {
        let e = Ltm::parse("objects([water]).\nschema(a, [], watr.used).").expect_err("unknown");
        assert!(matches!(e, Error::UnknownObject { ref name, line: 2, column: 15, .. } if name == "watr"), "{e}");
        let e = Ltm::parse("schema(a, [(b, true)], x.done).").expect_err("no schema for b");
        assert!(matches!(e, Error::UnknownBehaviour { .. }), "{e}");
    }

    #[test]
    fn save_is_atomic_and_reloads() {
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("ltm.schema");
        let ltm = Ltm::parse(BASE).expect("valid");
        ltm.save(&p).expect("save");
        let back = Ltm::load(&p).expect("load");
        assert_eq!(back, ltm);
        let names: Vec<_> = std::fs::read_dir(dir.path()).expect("ls").collect();
        assert_eq!(names.len(), 1, "no temporary file left behind");
    }
}
