"""Planning: A* search, fast cost-to-go tables, Q-values and the Boltzmann policy."""
