"""Claim-by-claim verification suite for the hidden-harmonic paper."""
