"""The same cart-pole without the cart bound: does solve(tolerance) meet it? (estimate only, no reference)"""
import sys, time, nc4
tol = float(sys.argv[1])
ocp = nc4.cartpole_model(None)
c = time.process_time(); sol = ocp.solve(tolerance=tol); mr = sol.mesh_refinement
print(tol, mr["met"], sol.transcription.scheme.point_count, round(time.process_time() - c, 1), mr["estimate"], sol.objective, mr["message"][:200])
