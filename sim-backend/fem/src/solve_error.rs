//! Why a solve failed: the error every solver in the crate returns (factorization, contact,
//! Newton).

#[derive(Debug, Clone, thiserror::Error)]
pub enum SolveError {
    #[error("sparse factorization failed: {0}")]
    Factor(String),
    #[error(
        "the stiffness is not positive definite (a rigid-body mode is unconstrained or an element is inverted)"
    )]
    NotPositiveDefinite,
    #[error("the solution has non-finite values")]
    NonFinite,
    #[error("element {0} is inverted or degenerate")]
    BadElement(usize),
    #[error("{0}")]
    NoConvergence(String),
    #[error("the lumen's wall: {0}")]
    BadLumen(String),
}
