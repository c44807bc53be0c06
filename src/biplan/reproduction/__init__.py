"""Reproduction of the paper's claims (``biplan reproduce``).

Read in this order:

* :mod:`~biplan.reproduction.facts` — the paper's reported numbers and the computed facts the
  claims read (:class:`~biplan.reproduction.facts.Results`), and the Fig. 3 B snapshot choice;
* :mod:`~biplan.reproduction.grading` — verdicts, always derived from computed checks;
* :mod:`~biplan.reproduction.claims` — every claim: its id, figure, section, the paper's words
  and its check, one module of checks per table of the report
  (:mod:`~biplan.reproduction.checks_fig3`, :mod:`~biplan.reproduction.checks_fig4`,
  :mod:`~biplan.reproduction.checks_si`);
* :mod:`~biplan.reproduction.settings` and :mod:`~biplan.reproduction.stages` — the
  computation, stage by stage (:mod:`~biplan.reproduction.figures` and
  :mod:`~biplan.reproduction.validation` write their files);
* :mod:`~biplan.reproduction.report` — the assessment and ``REPRODUCTION.md``.
"""
