"""Wind power for the hub: a 64 MW offshore farm at 1 s (`farm`) and generated years of it (`year`)."""
