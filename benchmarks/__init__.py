"""Side-by-side speed comparisons of manipkit with its peers (`make bench`; see README.md)."""
