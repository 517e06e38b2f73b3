"""The workflow's steps, one module per group of rules (workflow/rules/): dataset (sample,
export, sketch, points), train, evaluate (simplify, predict, rebuild, metrics), tables, report.
A step may import the steps before it, never one after."""
