"""What leaves the program: tables with provenance (io), provenance (provenance), figures (plots)
and PDF reports (report)."""
