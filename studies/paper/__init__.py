"""The paper's figures and table, reproduced (`lwrl reproduce`)."""
