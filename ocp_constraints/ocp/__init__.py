"""Optimal control: the problem, the collocation schemes (methods), the transcription into an IPOPT NLP
and the solution (uses mechanics and dynamics)."""
