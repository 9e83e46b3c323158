"""Running scenarios: the runner (simulate, fit, score), seeds and engines, Monte Carlo over
replicates, aggregation and statistics, claim maps and the suite."""
