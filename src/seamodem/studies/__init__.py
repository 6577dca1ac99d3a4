"""End-to-end studies: the whole chain (beacon → channel → receiver) run for a question, not a library stage.

:mod:`.ber` sweeps bit- and frame-error rates against SNR (``seamodem ber``).
The demo mission (:mod:`seamodem.demo`, ``seamodem demo``) is the other study.
"""
