"""ddoc.to_dataframe: a table of ddoc (a dict of equal-length NumPy arrays) as a pandas DataFrame.
pandas is optional: without it the tables stay dicts of arrays."""


def to_dataframe(table):
    """The table `table` (run_hopper's result or its 'trajectory', one map of robustness_map, or
    any dict of equal-length 1-D arrays) as a pandas DataFrame: one column per 1-D array, in
    order; the other plain values (method, fell, fall_reason, ...) go into DataFrame.attrs.
    Raises ImportError when pandas is not installed (apt-get install python3-pandas)."""
    try:
        import pandas
    except ImportError as e:
        raise ImportError("ddoc.to_dataframe needs pandas, which is not installed "
                          "(apt-get install python3-pandas); without it, use the dict of NumPy "
                          "arrays as it is") from e
    columns = {k: v for k, v in table.items() if getattr(v, "ndim", 0) == 1}
    frame = pandas.DataFrame(columns)
    frame.attrs.update({k: v for k, v in table.items()
                        if k not in columns and not isinstance(v, dict)})
    return frame
