"""The instruments: what each detector adds to the signal and how to take it off."""
