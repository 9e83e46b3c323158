"""fogbench simulation: rate table, thermal chamber, FOG error model, scenarios, runner."""
