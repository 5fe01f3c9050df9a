"""The controller: sampler spaces, cost, rollout engine, planners."""
