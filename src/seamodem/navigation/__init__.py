"""Navigation: the papers' estimators as consumers of the receiver's measurements."""
