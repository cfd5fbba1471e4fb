"""The knowledge-base compiler: resolution, semantic checks -> pydantic model, networkx net."""
