//! The grammar (`grammar/sde.pest`) and what its failures say: pest's rule names turned into
//! words a person expects ("expected an expression", not `operand`). Everything here knows the
//! grammar's rules; the rendering of a located message ([`super::diagnostic`]) does not.

use pest::error::{Error as PestError, ErrorVariant, InputLocation};

use super::ast::Span;

/// The pest parser generated from `grammar/sde.pest`.
#[derive(pest_derive::Parser)]
#[grammar = "grammar/sde.pest"]
pub(crate) struct SdeParser;

/// A syntax failure before rendering: where and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct SyntaxFailure {
    pub(crate) span: Span,
    pub(crate) message: String,
}

impl SyntaxFailure {
    /// Converts pest's error, naming rules for people (`expected `:``, not `colon`).
    pub(crate) fn from_pest(error: PestError<Rule>) -> SyntaxFailure {
        let span = match error.location {
            InputLocation::Pos(p) => Span::new(p, p),
            InputLocation::Span((s, e)) => Span::new(s, e),
        };
        let error = match error.variant {
            ErrorVariant::ParsingError {
                positives,
                negatives,
            } => PestError::new_from_pos(
                ErrorVariant::ParsingError {
                    positives: readable_positives(positives),
                    negatives,
                },
                pest::Position::from_start(""),
            ),
            other => PestError::new_from_pos(other, pest::Position::from_start("")),
        };
        let message = error
            .renamed_rules(describe_rule)
            .variant
            .message()
            .into_owned();
        SyntaxFailure { span, message }
    }
}

/// Folds the alternatives pest reports into what a person would expect to be told: the five
/// binary operators are "an operator", and where a statement may start, "end of line" adds
/// nothing, and `(` after a name is noise next to "an operator".
fn readable_positives(positives: Vec<Rule>) -> Vec<Rule> {
    let mut out: Vec<Rule> = Vec::new();
    for r in positives {
        let r = match r {
            Rule::sub | Rule::mul | Rule::div | Rule::pow => Rule::add,
            other => other,
        };
        if !out.contains(&r) {
            out.push(r);
        }
    }
    if out.contains(&Rule::statement) {
        out.retain(|r| *r != Rule::EOI);
    }
    // After a name, `(` would make it a call; next to "an operator" that only distracts.
    if out.contains(&Rule::add) {
        out.retain(|r| *r != Rule::lparen);
    }
    // Operators first, the end of the line last: the order in which a reader looks.
    out.sort_by_key(|r| match r {
        Rule::add => 0,
        Rule::EOI => 2,
        _ => 1,
    });
    out
}

/// The name of a grammar rule in an error message.
fn describe_rule(rule: &Rule) -> String {
    let s = match rule {
        Rule::statement => {
            "a statement (model, param, state, drift, noise, correlate, diffusion, \
             interpretation, impact, domain, observe, delta, safe or initial)"
        }
        Rule::EOI => "end of line",
        Rule::expr | Rule::operand | Rule::paren | Rule::call | Rule::number => "an expression",
        Rule::add | Rule::sub | Rule::mul | Rule::div | Rule::pow => "an operator",
        Rule::neg => "`-`",
        Rule::ident => "a name",
        Rule::binding => "`name = value`",
        Rule::description => "a quoted description",
        Rule::colon => "`:`",
        Rule::comma => "`,`",
        Rule::equals => "`=`",
        Rule::arrow => "`->`",
        Rule::above => "`>=` or `>`",
        Rule::below => "`<=` or `<`",
        Rule::domain_range | Rule::domain_bound | Rule::domain_periodic => {
            "`STATE >= BOUND`, `STATE <= BOUND`, `LOW <= STATE <= HIGH` or `STATE periodic \
             PERIOD`"
        }
        Rule::kw_periodic => "`periodic`",
        Rule::safe_range | Rule::safe_bound => {
            "`QUANTITY < BOUND`, `QUANTITY > BOUND` or `LOW < QUANTITY < HIGH`"
        }
        Rule::lparen => "`(`",
        Rule::rparen => "`)`",
        Rule::kw_intensity => "`intensity`",
        Rule::stratonovich => "`stratonovich`",
        Rule::ito => "`ito`",
        Rule::exact => "`exact`",
        Rule::kw_gaussian | Rule::gaussian => "`gaussian(width)`",
        Rule::kw_model => "`model`",
        Rule::kw_rest => "`rest`",
        Rule::kw_point | Rule::initial_point => "`point STATE = VALUE, ...`",
        Rule::kw_start_gaussian | Rule::initial_gaussian => {
            "`gaussian mean STATE = VALUE, ... cov XX, XV, VX, VV`"
        }
        Rule::kw_mean => "`mean`",
        Rule::kw_cov => "`cov`",
        other => return format!("{other:?}"),
    };
    s.to_string()
}
