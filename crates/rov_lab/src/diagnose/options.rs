//! The diagnosis's thresholds (the acceptance rules of [`super::judge`], the structural
//! inadequacy of a base, ambiguity) and its options.

/// Smallest held-out RMSE reduction that counts (fraction).
pub const MIN_REDUCTION: f64 = 0.15;
/// A channel counts only if its calibrated held-out RMSE is this many noise floors.
pub const NOISE_FACTOR: f64 = 1.3;
/// A worsened channel is tolerated when its noise-normalised loss is below this fraction
/// of the noise-normalised gain summed over channels (reported as a conflict).
pub const WORSE_FRACTION_OF_GAIN: f64 = 0.2;
/// Largest tolerated worsening of another channel (fraction).
pub const MAX_WORSE: f64 = 0.05;
/// A worsened channel whose held-out prediction moved by less than this fraction of its
/// noise floor (RMS) is within noise (see [`super::judge`]).
pub const WORSE_NOISE_FRACTION: f64 = 0.5;
/// Largest tolerated worsening of a channel the effect does not claim and the base
/// already misses structurally (fraction, see [`super::judge`]).
pub const MAX_WORSE_UNEXPLAINED: f64 = 0.25;
/// An effect parameter within this fraction of its range from a plausibility bound is
/// pinned there (see [`super::judge`]).
pub const BOUND_MARGIN: f64 = 0.03;
/// Training ΔBIC needed (effective sample size).
pub const MIN_DBIC: f64 = 10.0;
/// Own-term control: with the effect switched off again (base refit kept) the error must
/// rise by this fraction of the improvement, and by [`MIN_REDUCTION`] of itself.
pub const CONTROL_FRACTION: f64 = 0.1;
/// A thruster lag shorter than this fraction of the sample period is not resolvable (the
/// catalog asks for step edges sampled at ≥ 5/τ): a fit below one sample period stands in
/// for something else (issue 26's probe: a 40 ms lag at 20 Hz took the place of a missing
/// pitch moment).
pub const LAG_RESOLUTION: f64 = 1.0;
/// A model is structurally inadequate for the data when it misses at least
/// [`INADEQUATE_CHANNELS`] excited channels by more than this many noise floors
/// (multiple-shooting held-out RMSE): a finding that leaves it so ([`INADEQUATE_SHARE`])
/// and makes another excited channel clearly worse is then refused
/// (`judging::veto_on_inadequate_base`).
pub const INADEQUATE_FACTOR: f64 = 2.0;
/// See [`INADEQUATE_FACTOR`].
pub const INADEQUATE_CHANNELS: usize = 2;
/// A finding leaves a base structurally inadequate when the channels still beyond
/// [`INADEQUATE_FACTOR`] floors with it carry at least this share of the base's misfit
/// beyond that level (`judging::Inadequacy::left_by`).
pub const INADEQUATE_SHARE: f64 = 0.25;
/// Cosine similarity of prediction changes above which two findings are ambiguous.
pub const AMBIGUITY_COSINE: f64 = 0.9;

/// Options of [`super::diagnose`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Worker threads (1 = serial; default: every core). The result is the same for
    /// any count ([`crate::par`]).
    pub threads: usize,
    /// Most effects accepted.
    pub max_effects: usize,
    /// Candidates confirmed in simulation in the first round.
    pub confirm_first: usize,
    /// Candidates confirmed in later rounds.
    pub confirm_later: usize,
    /// LM iterations of the calibration stages.
    pub calibration_iterations: usize,
    /// LM iterations of a confirmation fit.
    pub confirm_iterations: usize,
    /// Most terms outside the catalog accepted (0 switches the term search off).
    pub max_terms: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            threads: crate::par::default_threads(),
            max_effects: 3,
            confirm_first: 3,
            confirm_later: 2,
            calibration_iterations: 8,
            confirm_iterations: 4,
            max_terms: 2,
        }
    }
}
