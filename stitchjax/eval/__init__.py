"""Evaluation: metrics, baselines, the official and diversity protocols, tables and figures."""
