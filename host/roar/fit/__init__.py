"""Fitting a simulated car to a real one (`roar fit`): what the car did with the pulses it was
sent, measured by a pose source, explained by a small model of its servo, ESC, motor and tyres.

    roar.fit.drive      the test drive: manoeuvres that keep to an area, by the car's pose
    roar.fit.log        a test drive's record (pulses sent, poses measured), from a run or an MCAP
    roar.fit.model      the car model a fit adjusts: servo, ESC, motor, brakes, tyres, delay
    roar.fit.identify   least squares of the model to a record, with confidence intervals
    roar.fit.report     the report plot: predicted against measured on a held-out manoeuvre

The model's numbers are the car's as a pose source sees it; roar_sim.runs.fit turns them into a
simulator car profile by driving the simulated car through the same test drive.
"""
