"""The run report: key figures (summary.parquet), plots and one self-contained HTML page. Pure building code:
tables in, strings / rows out; the `report` stage in seatune/pipeline/report.py reads and writes the files."""
