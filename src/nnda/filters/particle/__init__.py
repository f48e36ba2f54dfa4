"""Sequential Monte Carlo: resampling schemes (``resampling``), the state-space-model protocol (``ssm``) and
the particle filters over it (``smc``), batched over R runs x N particles. Nothing is imported here."""
