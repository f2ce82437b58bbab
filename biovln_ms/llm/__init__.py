"""LLM access through any OpenAI-compatible endpoint (DeepSeek by default)."""
