//! The discovered-terms layer of a [`LabModel`]: terms added by the term search
//! ([`crate::terms`]) and the filtered-command signals they read.

use rov_dynamics::Vector6;
use rov_dynamics::models::ModelState;

use super::{LabModel, MAX_FILTERS};
use crate::terms::{Term, TermInputs};

impl LabModel {
    /// Discovered terms of the model (in order of addition).
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    /// Adds a discovered term (coefficient as given); returns its index. A term of the
    /// same DOF and form replaces the old one's coefficient.
    pub fn add_term(&mut self, term: Term) -> usize {
        if let Some(i) = self
            .terms
            .iter()
            .position(|t| t.dof == term.dof && t.kind == term.kind)
        {
            if let Some(t) = self.terms.get_mut(i) {
                *t = term;
            }
            return i;
        }
        self.terms.push(term);
        if let Some(f) = term.kind.filter()
            && !self.filters.contains(&f)
            && self.filters.len() < MAX_FILTERS
        {
            self.filters.push(f);
        }
        self.refresh_name();
        self.terms.len() - 1
    }

    /// The filtered-command signals the terms use: (command index, filter index).
    pub fn filters(&self) -> &[(u8, u8)] {
        &self.filters
    }

    /// τ of the discovered terms for a state, command signals and filter states.
    #[inline]
    pub fn terms_tau(&self, state: &ModelState, cmd: &[f64], filt: &[f64]) -> Vector6 {
        let mut tau = Vector6::zeros();
        if self.terms.is_empty() {
            return tau;
        }
        let x = TermInputs {
            eta: &state.eta,
            nu: &state.nu,
            cmd,
            filt,
        };
        for t in &self.terms {
            let d = t.dof as usize;
            if d < 6 {
                tau[d] += t.coef * t.kind.value(&x) * self.drag_tau_factor[d];
            }
        }
        tau
    }
}
