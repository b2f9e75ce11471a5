"""The names records carry: protocol names and the labels of their ``condition`` field.

These are part of the results schema (``docs/results.md``): reports, figures and the
interpretability analysis select records by them, and the protocols write them, so both
sides import them from here (a reader of the closed-set records does not import the
closed-set protocol).

Examples
--------
>>> condition_reading("enrolled:force=1.4N,speed=6mm/s")
('enrolled', (1.4, 6.0))
>>> condition_reading("force=0.6N,speed=14mm/s")
(None, (0.6, 14.0))
>>> condition_reading(REFERENCE)
(None, None)
"""

from __future__ import annotations

from synth.presets import parse_condition

#: The paper's protocols (``protocol`` field), in the order ``benchmark all`` runs them.
CLOSED_SET = "closed-set"
CROSS_SHAPE = "cross-shape"
CROSS_MATERIAL = "cross-material"
PERTURBATION = "perturbation"
PAPER_PROTOCOLS: tuple[str, ...] = (CLOSED_SET, CROSS_SHAPE, CROSS_MATERIAL, PERTURBATION)
#: The protocols whose 1-shot curves are read against the closed-set reference curve.
GENERALISATION: tuple[str, ...] = (CROSS_SHAPE, CROSS_MATERIAL, PERTURBATION)

#: ``condition`` of the closed-set reference curve's records (``protocol="closed-set"``).
REFERENCE = "reference"
#: ``condition`` of the across-condition summary of the plain per-condition records (each
#: episode within one force/speed condition).
WITHIN_CONDITION = "within-condition"
#: ``condition`` of the perturbation protocol's records over all its trials as one pool.
POOLED = "pooled"
#: The enrolment reading's name: its per-condition records are ``"enrolled:<condition>"``,
#: its across-condition summary ``"enrolled"``.
ENROLLED = "enrolled"
#: Separates a reading's name from a force/speed condition in a record's ``condition``
#: (``"enrolled:force=1.4N,speed=6mm/s"``: the ``enrolled`` reading of that condition).
READING_SEPARATOR = ":"
#: The perturbation protocol's three readings (their summaries' ``condition``), in the
#: order the report lists them, each with what it means.
READINGS: tuple[tuple[str, str], ...] = (
    (WITHIN_CONDITION, "support and queries within one force/speed condition"),
    (POOLED, "support and queries drawn from all conditions' trials together"),
    (ENROLLED, "support from the nominal test half, queries from one perturbed condition"),
)


def condition_reading(condition: str | None) -> tuple[str | None, tuple[float, float] | None]:
    """``(reading, (force_n, speed_mm_s))`` of a record's ``condition``: ``(None, (1.4,
    6.0))`` for ``"force=1.4N,speed=6mm/s"``, ``("enrolled", (1.4, 6.0))`` for
    ``"enrolled:force=1.4N,speed=6mm/s"``; ``(None, None)`` for any other condition."""
    text = condition or ""
    reading, sep, rest = text.rpartition(READING_SEPARATOR)
    fs = parse_condition(rest if sep else text)
    if fs is None:
        return None, None
    return (reading or None) if sep else None, fs
