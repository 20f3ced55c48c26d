"""Expert datasets: collecting SimpleAgent games into Parquet shards, and streaming them back."""
