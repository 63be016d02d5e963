//! The diagnosis's last two steps: the **verdict** on the final model (adequate,
//! explained, unexplained: [`crate::verdict`]) and the **report** ([`Diagnosis`]): the
//! cards ranked, the baseline, the summary in words, the notes.

use rov_dynamics::models::Channel;

use crate::data::ch_name;
use crate::verdict::Unexplained;

use super::session::Session;
use super::tested::VerdictTests;
use super::*;

/// The verdict on the final model, with the channels it leaves inconsistent.
pub(super) struct Conclusion {
    pub(super) verdict: Verdict,
    /// Channels still inconsistent, with where their misfit lives.
    pub(super) unexplained: Vec<Unexplained>,
}

impl Session<'_> {
    /// The verdict: "adequate" when the final model's tests (`tests.last`) pass with
    /// nothing accepted, "explained" when they pass with findings, else "unexplained",
    /// with the inconsistent channels and where their misfit lives.
    pub(super) fn verdict(&self, tests: &VerdictTests) -> Conclusion {
        let last = &tests.last;
        let consistent = verdict::all_consistent(&last.tests);
        let any_finding = !self.accepted.is_empty() || !self.accepted_terms.is_empty();
        let verdict = match (consistent, any_finding) {
            (true, false) => Verdict::Adequate,
            (true, true) => Verdict::Explained,
            (false, _) => Verdict::Unexplained,
        };
        let unexplained = verdict::unexplained(&last.model, self.val, &last.eval, &last.tests);
        Conclusion {
            verdict,
            unexplained,
        }
    }

    /// The report: the accepted cards in order, then the other evaluated ones best
    /// first, then those never fitted; the calibrated base's per-channel baseline; the
    /// summary (what was found, trades, a structurally inadequate base); the notes on
    /// the data, the calibration and the verdict's refit. Consumes the session.
    pub(super) fn report(
        mut self,
        model_label: &str,
        tests: VerdictTests,
        c: Conclusion,
    ) -> Diagnosis {
        self.rank_findings();
        let base_note = self.base_note();
        let summary = self.summary(&c, base_note.as_ref());
        let mut data_notes = crate::ingest::treatment_sentences(self.train);
        for s in crate::ingest::treatment_sentences(self.val) {
            if !data_notes.contains(&s) {
                data_notes.push(s);
            }
        }
        let mut calibration_notes = crate::calibrate::calibration_notes(&self.cal, self.train);
        calibration_notes.extend(base_note);
        if !tests.last.moved.is_empty() {
            let moved: Vec<String> = tests
                .last
                .moved
                .iter()
                .map(|(k, a, b)| format!("{k} {a:.4} → {b:.4}"))
                .collect();
            calibration_notes.push(format!(
                "the verdict tests the model with its parameters refitted within their documented uncertainty (H₀: the model is right up to its parameters), which moved {}",
                moved.join(", ")
            ));
        }
        let not_predicted = Channel::ALL
            .into_iter()
            .filter(|ch| {
                self.val.iter().any(|r| r.has(*ch)) && !self.cal.model.predicts_channel(*ch)
            })
            .map(|ch| ch_name(ch).to_string())
            .collect();
        Diagnosis {
            model: model_label.to_string(),
            baseline: self.baseline(),
            not_predicted,
            calibration: self.cal.fitted,
            findings: self.findings,
            accepted: self.accepted,
            accepted_terms: self.accepted_terms,
            calibrated: self.cal.model,
            final_model: self.g.current.clone(),
            error_fall: self.error_fall,
            summary,
            verdict: c.verdict,
            consistency: tests.last.tests,
            consistency_base: tests.base.tests,
            unexplained: c.unexplained,
            data_notes,
            closed_loop: self.closed_loop,
            calibration_notes,
            search_notes: self.search_notes,
        }
    }

    /// Appends to the accepted cards the other evaluated ones (significant and ambiguous
    /// first, then not significant, then screened; by score, then ΔBIC) and those never
    /// fitted (not testable, not applicable, contained).
    fn rank_findings(&mut self) {
        let mut rest: Vec<Finding> = std::mem::take(&mut self.latest).into_values().collect();
        rest.append(&mut self.latest_terms);
        rest.sort_by(|a, b| {
            let rank = |f: &Finding| match f.status {
                Status::Ambiguous => 0,
                Status::Significant => 0,
                Status::NotSignificant => 1,
                Status::Screened => 2,
                _ => 3,
            };
            rank(a)
                .cmp(&rank(b))
                .then(b.score.total_cmp(&a.score))
                .then(
                    b.delta_bic
                        .unwrap_or(f64::NEG_INFINITY)
                        .total_cmp(&a.delta_bic.unwrap_or(f64::NEG_INFINITY)),
                )
        });
        self.findings.extend(rest);
        self.passive.sort_by_key(|f| match f.status {
            Status::NotTestable => 0,
            Status::NotApplicable => 1,
            _ => 2,
        });
        self.findings.append(&mut self.passive);
    }

    /// The calibrated base on the held-out runs, per channel, in both views.
    fn baseline(&self) -> BTreeMap<String, BaselineChannel> {
        self.base_eval
            .channels
            .iter()
            .map(|(k, c)| {
                (
                    k.name().to_string(),
                    BaselineChannel {
                        fit_pct: c.shooting.fit_pct,
                        rmse_shooting: c.shooting.rmse,
                        fit_pct_free_run: c.free_run.fit_pct,
                        rmse_free_run: c.free_run.rmse,
                        noise: c.noise,
                    },
                )
            })
            .collect()
    }

    /// A structurally inadequate base (`judging::inadequacy`), said with what it refused,
    /// only while it is true of the result: the accepted findings still leave a share of
    /// the base's misfit (`Inadequacy::left_by`; with nothing accepted, all of it), or a
    /// trading finding was refused. A base missing many channels because one effect is
    /// missing (the GUI's moment-arm case: pitch 25×, and five channels beyond 2× with
    /// it) is not called inadequate once that effect is found.
    fn base_note(&self) -> Option<String> {
        let refused: Vec<(String, Vec<String>)> = self
            .findings
            .iter()
            .filter(|f| !f.significant)
            .filter_map(|f| {
                let chans: Vec<String> = f
                    .conflicts
                    .iter()
                    .filter(|c| c.contains(BASE_VETO_MARK))
                    .filter_map(|c| c.split(" gets ").next().map(str::to_string))
                    .collect();
                (!chans.is_empty()).then(|| (f.effect.clone(), chans))
            })
            .collect();
        inadequacy_note(
            inadequacy(&self.base_eval, self.closed_loop).as_ref(),
            Inadequacy::left_by(&self.base_eval, &self.g.current_eval, self.closed_loop).as_ref(),
            &refused,
        )
    }

    /// The one-line summary: the verdict in words with what was found (and what is still
    /// unexplained), the accepted findings that trade another channel, and the base note
    /// unless the findings explain the data.
    fn summary(&self, c: &Conclusion, base_note: Option<&String>) -> String {
        let names = self.command_names();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let mut found: Vec<String> = self.accepted.iter().map(|e| e.key().to_string()).collect();
        found.extend(self.accepted_terms.iter().map(|t| t.id(&names)));
        // Accepted findings that trade another channel: said in the summary, not only in
        // their evidence cards.
        let traded: Vec<String> = self
            .findings
            .iter()
            .filter(|f| f.significant && !f.conflicts.is_empty())
            .map(|f| {
                let chans: Vec<&str> = f
                    .conflicts
                    .iter()
                    .filter_map(|c| c.split(" gets ").next())
                    .collect();
                format!(
                    "{} was accepted with a conflict: it leaves {} worse beyond the noise in a view (its conflicts say how much); a trade between channels usually means the base's structure is wrong or missing",
                    f.effect,
                    chans.join(", ")
                )
            })
            .collect();
        let summary = match c.verdict {
            Verdict::Adequate => "nothing significant: the calibrated model is adequate for this data (every channel within its noise floor and the uncertainty of its parameters and inputs)".to_string(),
            Verdict::Explained => format!(
                "found {}: with them the model is consistent with the held-out data (explained)",
                found.join(", then ")
            ),
            Verdict::Unexplained => {
                let u: Vec<String> = c
                    .unexplained
                    .iter()
                    .map(|u| {
                        let mut s = format!("{} {:.1}× its noise floor", u.channel, u.ratio);
                        if let Some(c) = u.where_.first() {
                            s.push_str(&format!(", mostly {}", c.description));
                        }
                        s
                    })
                    .collect();
                if found.is_empty() {
                    format!(
                        "nothing significant, but the model is not adequate for this data — unexplained: {}",
                        u.join("; ")
                    )
                } else {
                    format!(
                        "found {}; still unexplained: {}",
                        found.join(", then "),
                        u.join("; ")
                    )
                }
            }
        };
        let summary = if traded.is_empty() {
            summary
        } else {
            format!("{summary} ({})", traded.join("; "))
        };
        match base_note {
            Some(n) if !matches!(c.verdict, Verdict::Explained) => format!("{summary}. Note: {n}"),
            _ => summary,
        }
    }
}
