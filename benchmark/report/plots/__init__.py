"""Pictures (matplotlib, imported lazily inside each function). Every plot function takes ``ax=``
(a new figure when None) and returns what it drew."""
