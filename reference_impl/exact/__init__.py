"""The exact impact solver: quadrature in virtual time (no ODE), one impact or a batch."""
