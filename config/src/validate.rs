//! Semantic validation of typed configuration, collecting every problem with its field path.

/// A problem found in a value, named by its field path (`robot.pivot.min_depth_m`).
#[derive(Debug, Clone, PartialEq)]
pub struct FieldProblem {
    pub field: String,
    pub message: String,
}

/// Collects problems while walking a value; [`Validator::at`] scopes checks to a field.
#[derive(Debug, Default)]
pub struct Validator {
    prefix: Vec<String>,
    problems: Vec<FieldProblem>,
}

/// Implemented by every configuration section. Report problems, never panic.
pub trait Validate {
    fn validate(&self, v: &mut Validator);
}

impl Validator {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn into_problems(self) -> Vec<FieldProblem> {
        self.problems
    }

    /// Problems found so far: lets a section skip checks that need its fields to be sane.
    pub fn problem_count(&self) -> usize {
        self.problems.len()
    }

    fn path(&self, field: &str) -> String {
        let mut p = self.prefix.join(".");
        if !field.is_empty() {
            if !p.is_empty() && !field.starts_with('[') {
                p.push('.');
            }
            p.push_str(field);
        }
        p
    }

    /// Run `f` with checks scoped under `field`.
    pub fn at(&mut self, field: &str, f: impl FnOnce(&mut Validator)) {
        self.prefix.push(field.to_string());
        f(self);
        self.prefix.pop();
    }

    /// Validate a nested section under `field`.
    pub fn section(&mut self, field: &str, value: &impl Validate) {
        self.at(field, |v| value.validate(v));
    }

    pub fn problem(&mut self, field: &str, message: impl Into<String>) {
        let field = self.path(field);
        self.problems.push(FieldProblem {
            field,
            message: message.into(),
        });
    }

    pub fn check(&mut self, ok: bool, field: &str, message: impl Into<String>) {
        if !ok {
            self.problem(field, message);
        }
    }

    pub fn finite(&mut self, field: &str, value: f64) -> bool {
        let ok = value.is_finite();
        self.check(ok, field, format!("must be a finite number, got {value}"));
        ok
    }

    /// Finite and strictly positive.
    pub fn positive(&mut self, field: &str, value: f64) {
        if self.finite(field, value) {
            self.check(value > 0.0, field, format!("must be positive, got {value}"));
        }
    }

    /// Finite and not negative.
    pub fn non_negative(&mut self, field: &str, value: f64) {
        if self.finite(field, value) {
            self.check(
                value >= 0.0,
                field,
                format!("must not be negative, got {value}"),
            );
        }
    }

    /// Finite and within `[lo, hi]`.
    pub fn in_range(&mut self, field: &str, value: f64, lo: f64, hi: f64) {
        if self.finite(field, value) {
            self.check(
                (lo..=hi).contains(&value),
                field,
                format!("must be between {lo} and {hi}, got {value}"),
            );
        }
    }

    /// Each element positive.
    pub fn all_positive(&mut self, field: &str, values: &[f64]) {
        for (i, &x) in values.iter().enumerate() {
            self.positive(&format!("{field}[{i}]"), x);
        }
    }

    /// Each element finite.
    pub fn all_finite(&mut self, field: &str, values: &[f64]) {
        for (i, &x) in values.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), x);
        }
    }

    /// Each element not negative.
    pub fn all_non_negative(&mut self, field: &str, values: &[f64]) {
        for (i, &x) in values.iter().enumerate() {
            self.non_negative(&format!("{field}[{i}]"), x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Inner {
        gains: [f64; 2],
    }
    impl Validate for Inner {
        fn validate(&self, v: &mut Validator) {
            v.all_positive("gains", &self.gains);
        }
    }

    #[test]
    fn paths_nest_and_index() {
        let mut v = Validator::new();
        v.section("pd", &Inner { gains: [1.0, -2.0] });
        v.in_range("x", f64::NAN, 0.0, 1.0);
        let p = v.into_problems();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].field, "pd.gains[1]");
        assert_eq!(p[1].field, "x");
        assert!(p[1].message.contains("finite"));
    }
}
