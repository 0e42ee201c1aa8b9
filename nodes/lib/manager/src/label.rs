//! Action labels as the supervisor commands them: `functor(arg, …)` or a bare `functor`.

/// A parsed label.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// Functor, the primitive key (e.g. `foa1`).
    pub functor: String,
    /// Arguments (objects or `close` / `open`).
    pub args: Vec<String>,
}

impl Label {
    /// Parses `functor(a, b)`; the error says what is wrong.
    pub fn parse(text: &str) -> Result<Self, String> {
        let t = text.trim();
        let word = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        let (functor, args) = match t.split_once('(') {
            None => (t, Vec::new()),
            Some((f, rest)) => {
                let Some(inner) = rest.strip_suffix(')') else {
                    return Err(format!("label {text:?}: missing the closing `)`"));
                };
                let args: Vec<String> = inner.split(',').map(|a| a.trim().to_owned()).collect();
                if let Some(a) = args.iter().find(|a| !word(a)) {
                    return Err(format!("label {text:?}: argument {a:?} is not a word"));
                }
                (f.trim(), args)
            }
        };
        if !word(functor) {
            return Err(format!("label {text:?}: {functor:?} is not an action name"));
        }
        Ok(Self { functor: functor.to_owned(), args })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        assert_eq!(Label::parse("noa2(water)").unwrap(), Label { functor: "noa2".into(), args: vec!["water".into()] });
        assert_eq!(Label::parse(" gripper( close ) ").unwrap().args, vec!["close"]);
        assert!(Label::parse("foa1").unwrap().args.is_empty());
        assert!(Label::parse("foa1(water").unwrap_err().contains("closing"));
        assert!(Label::parse("(water)").is_err());
        assert!(Label::parse("foa1(wa ter)").is_err());
    }
}
