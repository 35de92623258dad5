"""The leaderboard's models, one module per kind: the domain (``domain``), what callers send
(``requests``), what they get back (``views``) and a board's export (``transfer``)."""
