"""The problem specification: problem files (TOML + pydantic), the design space, design
files and the validation of designs and parameters (docs/model.md §8, §15)."""
