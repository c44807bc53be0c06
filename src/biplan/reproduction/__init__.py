"""Reproduction of the paper's claims: the facts it reports, the claims checked per figure, the
stages of ``biplan reproduce`` and the report they write."""
