"""Receiver: front end, detection, time of flight, Doppler, compensation, measurement records."""
