"""URDFs and scenes shipped with opendyn."""
