"""The side panel's folders, one module each; each takes the MirrorscanApp and reads or calls what it needs."""
